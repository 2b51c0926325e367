"""Scenic's translation of a module, cached per source text (regen.driving.simulation.compile_cache):
the world model translated once per process, a program run through the cache records what it
records without it, Scenic's names restored, requirements never shared, threads one at a time."""

from __future__ import annotations

import contextlib
import threading

import pytest
from driving_chains import FEASIBLE

from regen.driving.grounding.rules import ground_rule_based
from regen.driving.simulation import compile_cache, parse_cache
from regen.driving.simulation.scenario import scenic_program, timing

scenic = pytest.importorskip("scenic")
from scenic.syntax import translator  # noqa: E402


@pytest.fixture(autouse=True)
def _empty_cache():
    compile_cache.clear()
    yield
    compile_cache.clear()


def _scenario(key: str = "stop_abruptly", i: int = 0):
    return ground_rule_based(FEASIBLE[key][i], seed=0)


def _columns(run) -> tuple:
    return tuple(getattr(run, c) for c in ("times", "x", "y", "heading", "speed"))


def test_the_world_model_is_translated_once_and_the_block_restores_scenic() -> None:
    from regen.driving.simulation.run import compile_program

    original = translator.compileStream
    text = scenic_program(_scenario())
    compile_program(text)
    misses, disk = compile_cache.stats["misses"], compile_cache.stats["disk"]
    assert misses >= 1 and misses + disk >= 2  # the program, and the world model's modules (maybe from disk)
    compile_program(text + "\n# another program text\n")
    assert compile_cache.stats["misses"] == misses + 1  # only the program itself
    assert compile_cache.stats["disk"] == disk  # the modules from the process's cache now
    assert compile_cache.stats["hits"] >= misses + disk - 1
    assert translator.compileStream is original
    with compile_cache.cached_compilation(), compile_cache.cached_compilation():  # nested: one patch
        assert translator.compileStream is not original
    assert translator.compileStream is original


def test_a_scenic_error_comes_through_and_scenic_is_restored() -> None:
    from regen.driving.simulation.run import compile_program
    from regen.errors import SimulationError

    original = translator.compileStream
    with pytest.raises(SimulationError, match="could not compile"):
        compile_program(scenic_program(_scenario()) + "\nx = (1,\n")
    assert translator.compileStream is original


def test_a_module_with_requirements_is_translated_every_time() -> None:
    from regen.driving.simulation.run import compile_program

    text = scenic_program(_scenario()) + "\nrequire ego.speed >= 0\n"
    for _ in range(2):
        compile_program(text)
    assert not any("require ego.speed" in source for _, _, source in compile_cache._cache)


@pytest.mark.slow
@pytest.mark.parametrize("key", ["stop_abruptly", "change_lane"])
def test_a_program_run_through_the_cache_records_what_it_records_without(key, monkeypatch) -> None:
    from regen.driving.simulation import run as run_module

    scenario = _scenario(key)
    text = scenic_program(scenario)
    dt, steps, seed = timing(scenario)

    def fresh() -> tuple:  # compiled again, not the compiled program kept from the run before
        run_module._RECENT.clear()
        return _columns(run_module.run_program(text, steps=steps, dt=dt, seed=seed))

    with monkeypatch.context() as m:
        m.setattr(compile_cache, "cached_compilation", contextlib.nullcontext)
        m.setattr(parse_cache, "cached_parsing", contextlib.nullcontext)
        plain = fresh()
    for _ in range(2):  # cold, then warm
        assert fresh() == plain
    assert compile_cache.stats["hits"] > 0


def _objects(compiled) -> list:
    return [(o.name, repr(o.position), repr(o.heading)) for o in compiled.objects] + sorted(compiled.params.items())


def test_threads_compile_one_at_a_time_and_get_what_one_thread_gets() -> None:
    """Scenic's compiler state is global: the lock makes concurrent compilations safe. (Scenic
    simulates in the main thread only: it sets a signal handler.)"""
    from regen.driving.simulation.run import compile_program

    texts = [scenic_program(_scenario(key)) for key in ("stop_abruptly", "drive_forward")]
    want = [_objects(compile_program(t)) for t in texts]
    compile_cache.clear()
    got: dict[int, list] = {}
    errors: list[BaseException] = []

    def compile_many(k: int) -> None:
        try:
            got[k] = [_objects(compile_program(texts[k])) for _ in range(3)]
        except BaseException as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)

    threads = [threading.Thread(target=compile_many, args=(k,)) for k in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors
    assert got[0] == [want[0]] * 3 and got[1] == [want[1]] * 3
    assert translator.compileStream.__name__ == "compileStream"
