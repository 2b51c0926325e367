"""Scenic's parse, cached per top-level statement (regen.driving.simulation.parse_cache): the same
tree as Scenic's own parse of the whole text, numbers put back where a statement's parse is
reused, and a scenario simulated through the cache records the trace it records without it."""

from __future__ import annotations

import ast
import contextlib
import io
import json
import tokenize
from pathlib import Path

import pytest
from driving_chains import FEASIBLE, chain_simulator

from regen.driving.grounding.rules import ground_rule_based
from regen.driving.simulation import compile_cache, parse_cache, scenic_disk
from regen.driving.simulation.scenario import scenic_program

scenic = pytest.importorskip("scenic")
from scenic.syntax import translator  # noqa: E402
from scenic.syntax.parser import parse_string  # noqa: E402

SCENIC_ROOT = Path(scenic.__file__).parent
WORLD_MODELS = sorted(str(p.relative_to(SCENIC_ROOT)) for p in SCENIC_ROOT.rglob("*.scenic"))  # all it ships
#: chains on both maps, a lane change, a traffic light, a crossing pedestrian
CHAINS = [("stop_abruptly", 0), ("stop_in_intersection", 0), ("change_lane", 0), ("drive_forward", 0)]
SNIPPETS = {
    "number glued to a keyword": "x = 1if True else 2\n",
    "numbers in case patterns": "match x:\n    case 1:\n        pass\n    case -2.5 | _:\n        y = 2\n",
    "a require probability": "require[0.5] ego.speed > 1\nrequire ego.speed > 2 as 12\n",
    "underscore names": "a, _ = f(3)\n_ = 5\nprint(_ + 7, _)\n",
    "non-ASCII before numbers": "n = 'é🐕' ; y = 12.5 + 3\nz = 'ü' + str(1e-3) + str(0x1F + 1_000 + 2j)\n",
    "attribute of a number": "x = 5..real + 1 .imag\n",
    "decorated and compound": ("@dec(1)\ndef f(a=2):\n    return a*3\nif x:\n    y = 1\nelif z:\n"
                               "    y = 2.5\nelse:\n    y = 3\ntry:\n    a = 1\nexcept E:\n    a = 2\n"
                               "finally:\n    b = 3\n"),
    "continued lines and comments": "x = [1,\n     2,  # two\n     3]\n\n# between\ny = \\\n    4\n",
    "no final newline": "x = 1\ny = 2",
    "signed numbers": ("x = (-1.5, 2, -3)\ny = f(a=-1, b=[-2, -3.5], c={1: -2}, d=x[1:-2], e=(- 4))\n"
                       "z = a -1\nw = a - -1\nv = 5 * -1 ** -2\nu = [(-1, -2), (-3, -4), (5, -6)]\n"),
    "strings as literals": ("n = 'ego'\nm = f(\"a\", 'b' 'c', x='d'.join([]), y=b'e', z=f'{n}', w='''t''')\n"
                            "k = ['x', 'y', 'z'] + [('a', 1), ('b', -2), ('c', 3)]\n"),
    "runs of like tuples": ("r = f([(1.5, -2.0), (3.25, -4.0), (5.0, -6.5), (-7.0, 8.0), (-9.5, 1.0), (-2.0, 3.0), "
                            "(4.0, 5.0)], [(1, 2, 3)], [(1, 2), (3, 4), (5, 6)], y[(1, 2), (3, 4), (5, 6)], "
                            "[(1, 'a'), (2, 'b'), (3, 'c')], [(1, 2), (3, 4), (5, 6), (7, 8)][0])\n"
                            "z = [(_, 1), (2, 3), (4, 5), (6, 7)] + [(1, 2),\n  (3, 4), (5, 6), (7, 8)]\n"),
}


def _dump(tree) -> str:
    return ast.dump(tree, include_attributes=True)


def _scenic_parse(text: str, mode: str = "exec"):
    return parse_string(text, mode, filename="<test>")


def _program(key: str, i: int) -> str:
    return scenic_program(ground_rule_based(FEASIBLE[key][i], seed=0))


def _renumbered(text: str, seed: int) -> str:
    """``text`` with every decimal number literal changed (its length with it; strings stay)."""
    lines = text.split("\n")
    numbers = [t for t in tokenize.generate_tokens(io.StringIO(text).readline)
               if t.type == tokenize.NUMBER and "." in t.string]
    for k, tok in enumerate(reversed(numbers)):
        (row, col), end = tok.start, tok.end[1]
        new = repr(round(float(tok.string) * 1.37 + seed + k % 7, 3))
        lines[row - 1] = lines[row - 1][:col] + new + lines[row - 1][end:]
    return "\n".join(lines)


@pytest.fixture(autouse=True)
def _empty_cache(tmp_path, monkeypatch):
    # nothing kept on disk by an earlier test's process either (regen.driving.simulation.scenic_disk)
    monkeypatch.setattr(scenic_disk, "FOLDER", str(tmp_path / "scenic-compiled"))
    parse_cache.clear()
    compile_cache.clear()
    yield
    parse_cache.clear()
    compile_cache.clear()


@pytest.mark.parametrize("key,i", CHAINS)
def test_a_program_parses_as_scenic_parses_it_cold_warm_and_with_other_numbers(key, i) -> None:
    text = _program(key, i)
    want = _dump(_scenic_parse(text))
    assert _dump(parse_cache.parse_module(text, _scenic_parse)) == want  # cold: every statement parsed
    misses = parse_cache.stats["misses"]
    assert _dump(parse_cache.parse_module(text, _scenic_parse)) == want  # warm: every statement reused
    assert parse_cache.stats["misses"] == misses
    other = _renumbered(text, 3)
    assert other != text
    assert _dump(parse_cache.parse_module(other, _scenic_parse)) == _dump(_scenic_parse(other))
    assert parse_cache.stats["misses"] == misses  # the same statements with other numbers: no parse


@pytest.mark.parametrize("path", WORLD_MODELS)
def test_scenic_world_models_parse_as_scenic_parses_them(path) -> None:
    text = (SCENIC_ROOT / path).read_text()
    assert _dump(parse_cache.parse_module(text, _scenic_parse)) == _dump(_scenic_parse(text))


@pytest.mark.parametrize("name", list(SNIPPETS))
def test_awkward_statements_parse_as_scenic_parses_them(name) -> None:
    text = SNIPPETS[name]
    for _ in range(2):  # cold, then from the cache
        assert _dump(parse_cache.parse_module(text, _scenic_parse)) == _dump(_scenic_parse(text))
    renumbered = _renumbered(text.replace("1", "9"), 1)
    assert _dump(parse_cache.parse_module(renumbered, _scenic_parse)) == _dump(_scenic_parse(renumbered))


def test_routes_of_other_lengths_share_a_parse() -> None:
    def program(n: int, m: int) -> str:
        route = ", ".join(f"({1.5 * k}, -{k + 0.25})" for k in range(n))
        route += "".join(f", (-{k}.5, {k})" for k in range(1, m + 1))
        return f"ego = new Car at (1, 2),\n    with behavior FollowRoute([{route}], [(0.0, 8.0, 0.0)], None)\n"

    for n, m in ((12, 0), (40, 5), (3, 3)):
        text = program(n, m)
        assert _dump(parse_cache.parse_module(text, _scenic_parse)) == _dump(_scenic_parse(text))
    misses = parse_cache.stats["misses"]
    for n, m in ((7, 0), (90, 4), (5, 30)):
        text = program(n, m)
        assert _dump(parse_cache.parse_module(text, _scenic_parse)) == _dump(_scenic_parse(text))
    assert parse_cache.stats["misses"] == misses


def test_a_number_where_a_name_parses_otherwise_is_parsed_as_written() -> None:
    for name in ("numbers in case patterns", "a require probability", "number glued to a keyword"):
        parse_cache.parse_module(SNIPPETS[name], _scenic_parse)
    assert parse_cache.stats["as_written"] >= 3


def test_compiling_through_the_cache_restores_scenics_parser_and_reports_scenics_errors() -> None:
    from regen.driving.simulation.run import compile_program
    from regen.errors import SimulationError

    original = translator.parse_string
    bad = _program("stop_abruptly", 0) + "\nx = (1,\n"
    with pytest.raises(SimulationError) as cached:
        compile_program(bad)
    assert translator.parse_string is original
    with pytest.raises(Exception) as plain:
        scenic.scenarioFromString(bad, filename="<regen>", mode2D=True)
    assert str(plain.value) in str(cached.value)  # Scenic's own message, line and all
    with parse_cache.cached_parsing(), parse_cache.cached_parsing():  # nested: one patch
        assert translator.parse_string is not original
    assert translator.parse_string is original


def test_compiling_leaves_the_garbage_collector_as_it_found_it() -> None:
    import gc

    from regen.driving.simulation.run import compile_program

    text = _program("stop_abruptly", 0)
    assert gc.isenabled()
    compile_program(text)
    assert gc.isenabled()
    gc.disable()
    try:
        compile_program(text)
        assert not gc.isenabled()  # a caller that turned it off keeps it off
    finally:
        gc.enable()


def test_the_cache_is_bounded(monkeypatch) -> None:
    monkeypatch.setattr(parse_cache, "MAX_CHARS", 400)
    for k in range(60):
        parse_cache.parse_module(f"x{k} = f(1, 'text {k}')\ny{k} = x{k} + 2\n", _scenic_parse)
    assert parse_cache._cached_chars <= 400 and len(parse_cache._cache) < 60


def _without_cache(monkeypatch) -> None:
    monkeypatch.setattr(parse_cache, "cached_parsing", contextlib.nullcontext)
    monkeypatch.setattr(compile_cache, "cached_compilation", contextlib.nullcontext)


@pytest.mark.slow
@pytest.mark.parametrize("key,i", CHAINS)
def test_a_scenario_simulated_through_the_cache_records_the_same_trace(key, i, monkeypatch) -> None:
    """Trace by trace, every recorded number: without the cache, with it cold, from cached parses,
    from a cached translation."""
    fresh = chain_simulator(key, i)  # compiled again, not the compiled program kept from the run before
    with monkeypatch.context() as m:
        _without_cache(m)
        plain = fresh()
    runs = [fresh()]  # cold: every statement parsed
    misses, hits = parse_cache.stats["misses"], parse_cache.stats["hits"]
    assert misses > 0
    compile_cache.clear()  # the program translated again, from the statements parsed before
    runs.append(fresh())
    assert parse_cache.stats["misses"] == misses and parse_cache.stats["hits"] > hits
    runs.append(fresh())  # warm: the translation itself from the process's cache
    assert compile_cache.stats["hits"] > 0
    for run in runs:
        for column in ("times", "x", "y", "heading", "speed"):
            assert getattr(run, column) == getattr(plain, column), column


@pytest.mark.slow
def test_the_main_jobs_stages_give_the_same_traces_and_verdicts_through_the_cache(tmp_path, monkeypatch) -> None:
    """run_path (simulate, verify, the causal check's reference runs) with and without the
    cache: trace.json and verdict.json identical, byte for byte."""
    from regen.driving.simulation import run as run_module
    from regen.driving.testing import loop
    from regen.pipeline import run_path

    def run(folder: Path) -> tuple[str, str]:
        monkeypatch.setattr(loop, "_COMPILED", {})  # the reference runs compile again, too
        run_module._RECENT.clear()
        outcome = run_path(FEASIBLE["slow_down"][2], folder, pictures=False)
        assert outcome.verdict.status != "simulation_failed", outcome.verdict.reason
        return (folder / "trace.json").read_text(), (folder / "verdict.json").read_text()

    with monkeypatch.context() as m:
        _without_cache(m)
        plain = run(tmp_path / "plain")
    cached = run(tmp_path / "cached")
    assert parse_cache.stats["misses"] > 0
    again = run(tmp_path / "again")
    assert cached == plain and again == plain
    assert json.loads(plain[1])["causal"]["status"] != "not_checked"
