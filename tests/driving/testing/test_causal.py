"""The but-for check in driving scenarios, simulated with the reference driver: a red light
beside a crossing child is a confounder, a cause too far away is no cause, grounding keeps a
context light from confounding, and removing a crossing cyclist leaves the stop unexplained."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from driving_chains import chain
from typer.testing import CliRunner

pytest.importorskip("scenic")

from regen import domains  # noqa: E402
from regen.cli import app  # noqa: E402
from regen.driving.grounding.rules import ground_rule_based  # noqa: E402
from regen.driving.testing.causal import reference_world  # noqa: E402
from regen.pipeline.stages import run_path  # noqa: E402
from regen.verify.causal import but_for, split_cast  # noqa: E402

pytestmark = pytest.mark.slow

CHILD = ("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})
RED = ("traffic_light", {"light_state": ["red"]})
CHILD_AND_LIGHT = chain("stop_abruptly", "a child runs across the road", CHILD, RED)


def _check(scenario):
    backend = domains.make("driving")
    cause, others, how = split_cast(scenario, backend.database(), robot=("ego-vehicle",))
    return but_for(reference_world(scenario, cause), cause, others, cause_from=how)


def test_a_red_light_beside_a_crossing_child_is_a_confounder():
    # the rule-based grounder on its own keeps the graph's red light (the backend would not)
    scenario = ground_rule_based(CHILD_AND_LIGHT)
    assert scenario.entity("traffic_light1").properties["light_state"] == "red"
    causal = _check(scenario)
    assert causal.cause == ["child1"] and causal.cause_from == "named by the cause's words"
    assert causal.status == "confounded" and causal.confounders == ["traffic_light1"], causal.reason
    (light,) = causal.others
    assert light.alone_shows and light.without_it_shows  # the child alone makes it stop too


def test_grounding_keeps_a_context_light_from_confounding_and_says_so(tmp_path):
    out = run_path(CHILD_AND_LIGHT, tmp_path / "01-child", pictures=False)
    scenario = json.loads((tmp_path / "01-child" / "scenario.json").read_text())["scenario"]
    light = next(e for e in scenario["entities"] if e["asset"] == "traffic_light")
    assert light["properties"]["light_state"] == "green"
    assert any("a confounder" in f and "red -> green" in f for f in out.verdict.fallbacks)
    assert out.verdict.feasible and out.verdict.causal.status == "caused", out.verdict.causal


def test_a_light_the_words_name_is_the_cause_and_keeps_its_state():
    scenario = domains.make("driving").ground(
        chain("stop_abruptly", "a child runs across the road at a red light", CHILD, RED), None)
    assert scenario.entity("traffic_light1").properties["light_state"] == "red"
    assert not any("confounder" in f for f in scenario.fallbacks)


def test_another_actors_red_light_is_not_the_egos():
    runner = chain("stop_in_intersection", "a car runs the red light from the cross street",
                   ("sedan", {"behavior": ["run_red_light"], "start_location": ["junction_cross_street"],
                              "target_speed": ["moderate"]}), RED)
    scenario = domains.make("driving").ground(runner, None)
    assert scenario.entity("traffic_light1").properties["light_state"] == "green"  # the runner's is red
    assert any("a confounder" in f for f in scenario.fallbacks)


def test_a_cause_too_far_away_to_matter_is_not_sufficient():
    scenario = ground_rule_based(chain("stop_abruptly", "a child runs across the road", CHILD))
    assert _check(scenario).status == "caused"
    far = scenario.model_copy(update={"parameters": {"child1": {**scenario.parameters["child1"],
                                                                "s": scenario.parameters["child1"]["s"] + 250.0}}})
    causal = _check(far)
    assert causal.status == "not_sufficient" and "does not stop" in causal.reason, causal.reason


def test_removing_the_crossing_cyclist_leaves_the_stop_unexplained(tmp_path):
    folder = tmp_path / "run" / "scenarios" / "01-cyclist"
    cyclist = chain("stop_abruptly", "a cyclist crosses the road",
                    ("bicycle", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}))
    out = run_path(cyclist, folder, pictures=False)
    assert out.verdict.feasible and out.verdict.causal.status == "caused", out.verdict.causal
    res = CliRunner().invoke(app, ["whatif", str(folder), "--remove", "bicycle1", "--no-judge", "--no-pictures",
                                   "--out", str(tmp_path / "whatif")], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    dest = Path(next(ln for ln in res.output.splitlines() if ln.startswith("wrote ")).split()[1])
    record = json.loads((dest / "whatif.json").read_text())
    assert not record["explained"] and record["original_explained"] and record["original_causal"] == "caused"
    assert "no longer explained" in res.output


def test_the_manipulation_domain_says_why_it_does_not_check():
    from regen.verify.causal import NotCheckable

    with pytest.raises(NotCheckable, match="only stand in place"):
        domains.make("manipulation").reference_world(None, [])  # type: ignore[arg-type]
