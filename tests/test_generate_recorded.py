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


def test_recorded_main_job_reports_what_it_cannot_ground_and_resumes(tmp_path: Path) -> None:
    """The offline model's recorded graph for the README job chose property values no primitive
    can honor (a stationary bicycle with a speed class; a pedestrian crossing from the oncoming
    lane). The main job says so, per scenario, instead of simulating something else."""
    pytest.importorskip("scenic", reason="the 'driving' extra is not installed")
    run = tmp_path / "run"
    run.mkdir()
    CallCache(run / "llm-cache.sqlite").import_json(CASSETTE)
    res = generate(BEHAVIOR, run, settings=RunSettings(llm="local", max_scenarios=2, pictures=True), replay=True)
    assert res.manifest.status == "done"
    assert res.manifest.usage["total"]["model_calls"] == 0
    assert [o.verdict.status for o in res.outcomes] == ["ungroundable", "ungroundable"]
    reasons = [o.verdict.reason for o in res.outcomes]
    assert "bicycle1: the graph's target_speed = 'slow' cannot be honored" in reasons[0]
    assert "adult1: the graph's start_location = 'oncoming_lane' cannot be honored" in reasons[1]
    for o in res.outcomes:  # nothing was simulated in place of what the graph decided
        assert not (o.path / "trace.json").exists() and (o.path / "verdict.json").exists()
    report = (run / "report.html").read_text()
    assert report.count("ungroundable") >= 2 and "cannot be honored" in report

    # a rerun skips every finished scenario and calls nothing
    shutil.rmtree(run / "scenarios" / res.outcomes[-1].folder)
    again = generate(BEHAVIOR, run, settings=RunSettings(llm="local", max_scenarios=2, pictures=False), replay=True)
    assert [o.skipped for o in again.outcomes] == [True] * (len(again.outcomes) - 1) + [False]
    assert again.outcomes[-1].verdict.status == res.outcomes[-1].verdict.status
    assert again.manifest.usage_last["total"]["model_calls"] == 0
