"""What Scenic made of fixed text, kept on disk for the next process
(regen.driving.simulation.scenic_disk): a process whose caches are empty reads the world model's
translations and the warm-up program's parses instead of making them, compiles what it compiled
without them, and never reads a file it cannot trust to be the same (damaged, another Scenic)."""

from __future__ import annotations

import contextlib

import pytest
from driving_chains import FEASIBLE

from regen.driving.grounding.rules import ground_rule_based
from regen.driving.simulation import compile_cache, parse_cache, scenic_disk
from regen.driving.simulation.run import compile_program
from regen.driving.simulation.scenario import scenic_program
from regen.driving.simulation.warm import warm

pytest.importorskip("scenic")


@pytest.fixture(autouse=True)
def _own_folder(tmp_path, monkeypatch):
    """An empty folder of kept files per test (the maps stay in the session's cache), and empty
    process caches before and after: each test starts as a new process on a new machine."""
    monkeypatch.setattr(scenic_disk, "FOLDER", str(tmp_path / "scenic-compiled"))
    compile_cache.clear()
    parse_cache.clear()
    yield tmp_path / "scenic-compiled"
    compile_cache.clear()
    parse_cache.clear()


def _new_process() -> None:
    compile_cache.clear()
    parse_cache.clear()


def _objects(compiled) -> list:
    return [(o.name, repr(o.position), repr(o.heading), repr(o.behavior)) for o in compiled.objects] + \
        sorted(compiled.params.items())


def _program(key: str = "stop_abruptly") -> str:
    return scenic_program(ground_rule_based(FEASIBLE[key][0], seed=0))


def _plain(text: str, monkeypatch) -> list:
    with monkeypatch.context() as m:
        m.setattr(compile_cache, "cached_compilation", contextlib.nullcontext)
        m.setattr(parse_cache, "cached_parsing", contextlib.nullcontext)
        return _objects(compile_program(text))


def test_a_new_process_reads_what_the_first_one_made_and_compiles_the_same(_own_folder, monkeypatch) -> None:
    warm()
    made = compile_cache.stats["misses"]
    assert made >= 3 and compile_cache.stats["disk"] == 0  # the program and the world model's modules
    kinds = sorted(p.name.split("-")[0] for p in _own_folder.glob("*.bin"))
    assert kinds == ["module"] * (made - 1) + ["parses"]
    _new_process()
    warm()
    assert compile_cache.stats["disk"] == made - 1  # every module read, not translated
    assert compile_cache.stats["misses"] == 1  # the ego-only program, translated from kept parses
    assert parse_cache.stats["misses"] == 0 and parse_cache.stats["hits"] > 0
    for key in ("stop_abruptly", "change_lane"):
        text = _program(key)
        assert _objects(compile_program(text)) == _plain(text, monkeypatch)


def test_a_damaged_file_is_made_again_and_nothing_changes(_own_folder, monkeypatch) -> None:
    warm()
    parsed = parse_cache.stats["misses"]
    files = sorted(_own_folder.glob("*.bin"))
    for i, path in enumerate(files):  # cut short, emptied, or another layout
        data = path.read_bytes()
        path.write_bytes([data[: len(data) // 2], b"", b"NOTREGEN" + data[8:]][i % 3])
    _new_process()
    warm()
    assert compile_cache.stats["disk"] == 0 and parse_cache.stats["misses"] == parsed  # nothing damaged was read
    text = _program()
    assert _objects(compile_program(text)) == _plain(text, monkeypatch)
    _new_process()
    warm()  # the files were written again, whole
    assert compile_cache.stats["disk"] >= 2 and parse_cache.stats["misses"] == 0


def test_another_scenic_version_never_reads_the_files(_own_folder, monkeypatch) -> None:
    warm()
    parsed = parse_cache.stats["misses"]
    _new_process()
    monkeypatch.setattr(scenic_disk, "_scenic_version", lambda: b"3.99.0")
    warm()
    assert compile_cache.stats["disk"] == 0 and parse_cache.stats["misses"] == parsed


def test_the_folder_keeps_at_most_max_files(_own_folder, monkeypatch) -> None:
    monkeypatch.setattr(scenic_disk, "MAX_FILES", 2)
    warm()
    assert len(list(_own_folder.glob("*.bin"))) == 2
    assert not list(_own_folder.glob(".tmp-*"))


def test_a_folder_that_cannot_be_written_only_costs_time(_own_folder, monkeypatch) -> None:
    _own_folder.parent.joinpath("scenic-compiled").write_text("a file where the folder should be")
    text = _program()
    warm()  # cache_dir cannot make the folder: nothing kept, nothing failed
    assert _objects(compile_program(text)) == _plain(text, monkeypatch)


def test_a_process_that_does_not_warm_up_reads_the_kept_parses_at_its_first_compilation(monkeypatch) -> None:
    text = _program()
    warm()
    with monkeypatch.context() as m:  # a process with the modules kept on disk and no parses
        _new_process()
        m.setattr(scenic_disk, "read_parses", lambda: None)
        compile_program(text)
        cold = parse_cache.stats["misses"]
    _new_process()  # e.g. `regen generate`: its first scenario, no warm-up
    compiled = _objects(compile_program(text))
    assert 0 < parse_cache.stats["misses"] < cold / 2  # the actors' statements; the helpers were kept
    assert compiled == _plain(text, monkeypatch)
