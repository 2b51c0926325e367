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


def test_recorded_main_job_produces_a_feasible_scenario_and_a_report(tmp_path: Path) -> None:
    pytest.importorskip("scenic", reason="the 'driving' extra is not installed")
    run = tmp_path / "run"
    run.mkdir()
    CallCache(run / "llm-cache.sqlite").import_json(CASSETTE)
    res = generate(BEHAVIOR, run, settings=RunSettings(llm="local", max_scenarios=2, pictures=True), replay=True)
    assert res.manifest.status == "done"
    assert res.manifest.usage["total"]["model_calls"] == 0
    assert res.feasible >= 1
    feasible = next(o for o in res.outcomes if o.verdict.feasible)
    folder = run / "scenarios" / feasible.folder
    for f in ("scenario.json", "verdict.json", "trace.json", "scenario.scenic", "bird_eye.gif", "scenario.xosc"):
        assert (folder / f).exists(), f
    verdict = json.loads((folder / "verdict.json").read_text())
    assert verdict["feasible"] is True and all(s["reached_at"] is not None for s in verdict["stages"])
    report = (run / "report.html").read_text()
    assert feasible.folder in report and "bird_eye.gif" in report

    # a rerun skips every finished scenario and calls nothing
    shutil.rmtree(run / "scenarios" / res.outcomes[-1].folder)
    again = generate(BEHAVIOR, run, settings=RunSettings(llm="local", max_scenarios=2, pictures=False), replay=True)
    assert [o.skipped for o in again.outcomes] == [True] * (len(again.outcomes) - 1) + [False]
    assert again.outcomes[-1].verdict.status == res.outcomes[-1].verdict.status
