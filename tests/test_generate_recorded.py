"""The main job end to end on the real driving simulator, with the offline model's recorded
answers (scripts/record_cassettes.py generate): no model is loaded, nothing is called."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from regen.core.behavior import Behavior
from regen.llm.cache import CallCache
from regen.pipeline import RunSettings, generate

CASSETTE = Path(__file__).resolve().parent / "data" / "cassettes" / "generate_driving.json"
BEHAVIOR = Behavior(text="the ego-vehicle stops abruptly while driving forward", domain="driving")

pytestmark = pytest.mark.slow


def _interop_tools() -> bool:
    """Whether the ASAM checkers (.venv-qc) and the carla client are here; CI installs both."""
    import os

    try:
        import carla  # noqa: F401

        from regen.driving.interop.qc import program

        program(".xodr")
        program(".xosc")
    except Exception:
        if os.environ.get("CI"):
            raise
        return False
    return True


def test_recorded_main_job_verifies_distinct_causes_as_the_graph_chose_and_resumes(tmp_path: Path) -> None:
    """The README job with the offline model's recorded answers: at least three scenarios with
    distinct causes, each verified and caused with its cause's actor doing what the graph chose,
    a GIF each; where the rules replaced a model answer, the verdict says so."""
    pytest.importorskip("scenic", reason="the 'driving' extra is not installed")
    run = tmp_path / "run"
    run.mkdir()
    CallCache(run / "llm-cache.sqlite").import_json(CASSETTE)
    res = generate(BEHAVIOR, run, settings=RunSettings(llm="local", pictures=True), replay=True)
    assert res.manifest.status == "done"
    assert res.manifest.usage["total"]["model_calls"] == 0
    assert len(res.outcomes) >= 3 and all(o.verdict.feasible for o in res.outcomes), \
        [(o.verdict.status, o.verdict.reason) for o in res.outcomes]
    for o in res.outcomes:  # a relaxed one says what was relaxed: a state the model got wrong
        if o.verdict.status != "verified":
            assert o.verdict.status == "verified_after_relaxation" and o.verdict.relaxations
            assert all("dropped the model's state" in r for r in o.verdict.relaxations)
    causes = [o.scenario().causal_graph[0] for o in res.outcomes]
    assert len(set(causes)) == len(causes)
    # verified means caused: the reference driver stops for each cause and not without it; the
    # red light the graph put beside the pedestrian was kept green by grounding, and says so
    assert [o.verdict.causal.status for o in res.outcomes] == ["caused"] * len(res.outcomes), \
        [o.verdict.causal.reason for o in res.outcomes]
    assert any("a confounder" in f for o in res.outcomes for f in o.verdict.fallbacks)
    graph = json.loads((run / "graph.json").read_text())
    chosen = {}  # asset -> property -> accepted values in the graph
    for n in graph["nodes"].values():
        if n["kind"] == "property" and n["status"] == "accepted":
            ent = graph["nodes"][next(e["target"] for e in graph["edges"] if e["source"] == n["id"])]
            chosen.setdefault(ent["asset"] or ent["label"], {}).setdefault(n["property"], []).append(n["value"])
    from regen.driving.grounding.rules import roles_of

    sources = []
    for o in res.outcomes:
        sc = o.scenario()
        sources.append(sc.fsm_source)
        if sc.fsm_source == "rules":  # the model's FSM was thrown away: the verdict tells
            assert any(f.startswith("ground_fsm:") and "used the rules" in f for f in o.verdict.fallbacks)
        for role in roles_of(sc):
            want = chosen[role.asset]
            if "behavior" in want:
                assert role.primitive in want["behavior"]
            if "start_location" in want:
                assert role.location in want["start_location"]
        assert (o.path / "bird_eye.gif").stat().st_size > 10_000
    # every FSM answer validated at once: none thrown away for the rules, no re-ask
    assert "rules" not in sources
    assert res.manifest.usage["by_purpose"]["ground_fsm"]["reasks"] == 0
    report = (run / "report.html").read_text()
    assert report.count("verified") >= 3

    # every scenario runs elsewhere and comes back: both ASAM bundles, a cause started on the ego
    # where its trigger is relative, the CARLA program on CARLA's map, the import round trip
    if _interop_tools():
        from regen.driving.interop.roundtrip import check_folder

        maps: set[str] = set()
        for o in res.outcomes:
            check = check_folder(o.path, maps_seen=maps)
            assert check.ok, check.line()
            assert check.max_error < 0.01, check.line()

    # a rerun skips every finished scenario and calls nothing
    shutil.rmtree(run / "scenarios" / res.outcomes[-1].folder)
    again = generate(BEHAVIOR, run, settings=RunSettings(llm="local", pictures=False), replay=True)
    assert [o.skipped for o in again.outcomes] == [True] * (len(again.outcomes) - 1) + [False]
    assert again.outcomes[-1].verdict.status == res.outcomes[-1].verdict.status
    assert again.manifest.usage_last["total"]["model_calls"] == 0
