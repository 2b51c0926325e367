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


def test_a_context_light_the_ego_cannot_meet_after_its_turn_is_left_out_and_said(tmp_path):
    """Seen in a batch: the user's cause 'a pedestrian crosses the side road the ego-vehicle
    turns into' got a traffic light from the model; after its turn the ego is past the
    junction, so no map hosts a light and the user's cause failed to ground. The light (not
    named by the cause) is left out, the verdict says so, and the pedestrian's scenario runs."""
    adult = ("adult", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"],
                       "target_speed": ["fast"]})
    path = chain("stop_after_turn", "a pedestrian crosses the side road the ego-vehicle turns into", adult, RED)
    with pytest.raises(Exception, match="cannot host traffic_light1"):
        ground_rule_based(path)  # the rules alone: the light cannot be placed
    out = run_path(path, tmp_path / "01-adult", pictures=False)
    scenario = json.loads((tmp_path / "01-adult" / "scenario.json").read_text())["scenario"]
    assert [e["asset"] for e in scenario["entities"] if e["name"] != "ego"] == ["adult"]
    (note,) = [f for f in out.verdict.fallbacks if "left out" in f]
    assert note.startswith("traffic_light left out: the cause's words do not name this traffic light")
    assert "after its turn the ego is past the junction" in note
    assert out.verdict.status != "grounding_failed", out.verdict.reason


def test_a_light_the_words_name_is_never_left_out():
    """The same ego behavior with a cause that names the light: it stays, and the scenario is
    ungroundable with the reason (a light the ego cannot meet cannot be the cause)."""
    path = chain("stop_after_turn", "a traffic light turns red just as the vehicle turns right", RED)
    with pytest.raises(Exception, match="cannot host traffic_light1"):
        domains.make("driving").ground(path, None)


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


def test_a_run_without_an_entity_reuses_the_whole_worlds_program_and_records_what_its_own_does():
    """The reference runs without some entities generate the whole world's compiled program
    and leave those objects out: the same trace as compiling the smaller world's program."""
    from regen.driving.testing import loop
    from regen.driving.testing.causal import without
    from regen.driving.testing.reference import ReferenceDriver

    scenario = ground_rule_based(CHILD_AND_LIGHT)
    whole = loop.prepare(scenario)
    for removed in ({"child1"}, {"traffic_light1"}):
        world = without(scenario, frozenset(removed))
        shared = loop.prepare(world, within=whole)
        assert shared.leave_out == frozenset(removed) and shared.compiled is whole.compiled
        own = loop.prepare(world)
        assert not own.leave_out and own.compiled is not whole.compiled
        traces = [loop.run_policy(p, ReferenceDriver(), step_timeout=None).trace for p in (shared, own)]
        assert traces[0].model_dump_json() == traces[1].model_dump_json()
        assert not set(removed) & set(traces[0].actors)


def test_a_run_asked_for_twice_is_simulated_once_and_handed_out_as_a_copy():
    world = reference_world(ground_rule_based(CHILD_AND_LIGHT), ["child1"])
    first = world.run(frozenset())
    first.removed = ["changed by the caller"]
    again = world.run(frozenset())
    assert again.removed == [] and again == world.run(frozenset())
    assert len(world._runs) == 1


def test_the_reference_world_reuses_the_scripted_program_just_run_and_records_what_its_own_does():
    """After the simulate stage ran the scenario's program, the reference world generates that
    compiled program and drops the ego's behavior: the same trace as compiling its own."""
    from regen.driving.simulation.scenario import scenic_program, timing
    from regen.driving.testing import loop
    from regen.driving.testing.reference import ReferenceDriver

    scenario = ground_rule_based(CHILD_AND_LIGHT)
    assert loop._without_ego_behavior("ego = new Car at (1, 2),\n    with name 'ego'\n") is None
    dt, steps, seed = timing(scenario)
    from regen.driving.simulation.run import run_program

    run_program(scenic_program(scenario), steps=steps, dt=dt, seed=seed)
    loop._COMPILED.clear()
    shared = loop.prepare(scenario)
    assert shared.scripted_ego and not shared.leave_out
    own = loop._compiled_here(shared)
    assert not own.scripted_ego and own.compiled is not shared.compiled
    within = loop.prepare(scenario, within=shared)  # a world within it inherits the dropped behavior
    assert within.scripted_ego and within.compiled is shared.compiled
    traces = [loop.run_policy(p, ReferenceDriver(), step_timeout=None).trace for p in (shared, own)]
    assert traces[0].model_dump_json() == traces[1].model_dump_json()


def test_following_a_turn_is_no_lane_change_and_going_round_debris_is_one():
    from driving_chains import FEASIBLE

    turn = ground_rule_based(FEASIBLE["stop_after_turn"][1])  # a box on the side road after the turn
    world = reference_world(turn, ["box1"])
    without = world.run(frozenset({"box1"}))  # it turns right and drives on
    assert not without.shown and "changes lane" not in without.summary, without.summary
    debris = ground_rule_based(FEASIBLE["change_lane"][1])  # straight road, debris in the lane
    run = reference_world(debris, ["debris1"]).run(frozenset())
    assert run.shown and run.summary.startswith("changes lane at t = "), run.summary
