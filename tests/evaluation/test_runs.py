"""Reading run folders, and the feasibility breakdown built from them."""

from __future__ import annotations

import json

import pytest

from regen.core.io import write_json
from regen.errors import ConfigError
from regen.evaluation.feasibility import feasibility_breakdown
from regen.evaluation.runs import load_run


@pytest.fixture
def run_dir(tmp_path, scenario_factory, verdict_factory):
    run = tmp_path / "run1"
    write_json(run / "run.json", {"behavior": {"text": "the ego-vehicle stops abruptly",
                                               "domain": "driving"}, "settings": {}})
    s1 = scenario_factory("s1", ["ambulance approaching from behind"],
                          "An ambulance approaches, the ego stops.", {"siren": "on"})
    s2 = scenario_factory("s2", ["a jaywalker walked in front"], "")
    s3 = scenario_factory("s3", ["debris in the road"], "Debris lies in the lane.")
    write_json(run / "scenarios" / "s1" / "scenario.json", {"scenario": s1.model_dump(mode="json")})
    write_json(run / "scenarios" / "s1" / "verdict.json", verdict_factory(True))
    write_json(run / "scenarios" / "s2" / "scenario.json", s2)  # the model itself, not wrapped
    write_json(run / "scenarios" / "s2" / "verdict.json", verdict_factory(False))
    write_json(run / "scenarios" / "s3" / "scenario.json", s3)  # no verdict yet
    # grounding failed: only a verdict
    write_json(run / "scenarios" / "s4" / "verdict.json",
               verdict_factory(False, "grounding_failed", "no entity for 'a tree fell'"))
    # an older, looser format and a corrupt verdict
    (run / "scenarios" / "s5").mkdir(parents=True)
    (run / "scenarios" / "s5" / "scenario.json").write_text(json.dumps(
        {"narrative": "Old format.", "causal_graph": ["fog", "the ego-vehicle stops abruptly"],
         "entities": [{"name": "car", "properties": {"hazard_lights": "on"}}]}))
    (run / "scenarios" / "s5" / "verdict.json").write_text("{truncated")
    return run


def test_load_run_reads_every_format(run_dir):
    run = load_run(run_dir)
    assert run.behavior == "the ego-vehicle stops abruptly"
    assert run.domain == "driving"
    by = {s.id: s for s in run.scenarios}
    assert set(by) == {"s1", "s2", "s3", "s4", "s5"}
    assert by["s1"].text == "An ambulance approaches, the ego stops."
    assert by["s1"].causes == ["ambulance approaching from behind"]
    assert by["s1"].properties["actor1"] == {"siren": "on"}
    assert (by["s1"].feasible, by["s1"].status) == (True, "verified")
    # empty narrative: the chain stands in for it
    assert by["s2"].text == "a jaywalker walked in front -> the ego-vehicle stops abruptly"
    assert (by["s3"].feasible, by["s3"].status) == (None, "missing")
    assert by["s4"].status == "grounding_failed" and by["s4"].text == ""
    assert by["s5"].causes == ["fog"] and by["s5"].text == "Old format."
    assert by["s5"].properties == {"car": {"hazard_lights": "on"}}
    assert any("unreadable" in n for n in by["s5"].notes)
    assert by["s5"].feasible is None


def test_feasibility_breakdown_counts(run_dir):
    rep = feasibility_breakdown([load_run(run_dir)])
    assert len(rep.behaviors) == 1
    b = rep.behaviors[0]
    assert (b.scenarios, b.evaluated, b.feasible) == (5, 3, 1)
    assert b.success_rate == pytest.approx(1 / 3)
    assert b.statuses == {"fsm_incomplete": 1, "grounding_failed": 1, "missing": 2, "verified": 1}
    rows = {r.scenario: r for r in rep.scenarios}
    assert rows["s4"].reason == "no entity for 'a tree fell'"
    assert rep.total.feasible == 1


def test_two_runs_of_two_behaviors(run_dir, tmp_path, scenario_factory, verdict_factory):
    other = tmp_path / "run2"
    write_json(other / "run.json", {"behavior": "the robot opens the door"})
    s = scenario_factory("m1", ["the pet is outside"], "Let the pet in.")
    data = s.model_dump(mode="json")
    data["behavior"]["text"] = "the robot opens the door"
    data["causal_graph"][-1] = "the robot opens the door"
    write_json(other / "scenarios" / "m1" / "scenario.json", data)
    write_json(other / "scenarios" / "m1" / "verdict.json", verdict_factory(True))
    rep = feasibility_breakdown([load_run(run_dir), load_run(other)])
    assert [b.behavior for b in rep.behaviors] == ["the ego-vehicle stops abruptly",
                                                   "the robot opens the door"]
    assert rep.behaviors[1].success_rate == 1.0
    assert (rep.total.evaluated, rep.total.feasible) == (4, 2)


def test_not_a_run_folder(tmp_path):
    with pytest.raises(ConfigError, match="not a run folder"):
        load_run(tmp_path)
