"""Done-when: per ego behavior, three or more hand-written chains ground, simulate and verify;
impossible chains are reported with reasons; generated Scenic files compile."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the tests folder is not a package
from driving_chains import FEASIBLE, IMPOSSIBLE  # noqa: E402

pytest.importorskip("scenic")

from regen.driving.backend import DrivingBackend, run_path  # noqa: E402

CASES = [(k, i) for k, paths in FEASIBLE.items() for i in range(len(paths))]
_RESULTS: dict = {}


def result(key, i):
    if (key, i) not in _RESULTS:
        _RESULTS[(key, i)] = run_path(FEASIBLE[key][i])
    return _RESULTS[(key, i)]


@pytest.mark.slow
@pytest.mark.parametrize("key,i", CASES)
def test_chain_is_verified(key, i):
    r = result(key, i)
    assert r.verdict.status == "verified", r.verdict.reason
    assert r.trace is not None and set(r.trace.actors) == {e.name for e in r.scenario.entities}
    assert r.trace.meta["map_path"].endswith(".xodr")
    assert r.scenario.world["grounder"] == "rule-based"


@pytest.mark.slow
def test_each_behavior_has_three_feasible_chains():
    assert all(len(v) >= 3 for v in FEASIBLE.values()) and len(FEASIBLE) == 6


@pytest.mark.slow
def test_ego_stops_before_the_pedestrians_path():
    r = result("stop_abruptly", 0)
    tr = r.trace
    ego, child = tr.actors["ego"], tr.actors["child1"]
    assert ego.speed[-1] < 0.1
    assert ego.x[-1] + ego.length / 2 < child.x[0]  # front bumper short of the crossing line
    assert min(child.y) < -1.75 < max(child.y)  # the child did cross the ego's lane


@pytest.mark.slow
def test_ambulance_ends_in_front_of_the_ego_with_siren_on():
    tr = result("stop_abruptly", 1).trace
    amb, ego = tr.actors["ambulance1"], tr.actors["ego"]
    assert amb.x[0] < ego.x[0] and amb.x[-1] > ego.x[-1] + 5
    assert set(amb.states["siren"]) == {"on"}


@pytest.mark.slow
def test_ego_stops_inside_the_junction_and_red_light_runner_crosses():
    tr = result("stop_in_intersection", 0).trace
    assert tr.actors["ego"].states["in_junction"][-1] is True
    assert any(tr.actors["sedan1"].states["in_junction"])


@pytest.mark.parametrize("key,status,words", [
    ("slow_lead_brakes", "unsatisfiable", "as fast as the ego"),
    ("no_adjacent_lane", "grounding_failed", "cannot host"),
    ("contradictory", "grounding_failed", "contradictory"),
    ("unsupported_behavior", "grounding_failed", "cannot 'drive_forward'"),
])
def test_impossible_chains_are_recorded_not_raised(key, status, words):
    r = run_path(IMPOSSIBLE[key])
    assert not r.verdict.feasible and r.verdict.status == status
    assert words in r.verdict.reason


@pytest.mark.slow
def test_export_writes_config_and_a_scenic_file_that_compiles(tmp_path):
    import scenic

    from regen.driving.backend import write_outputs

    r = result("stop_abruptly", 1)
    files = write_outputs(r, tmp_path)
    import json

    cfg = json.loads(files["scenario"].read_text())["config"]
    assert cfg["causal_graph"] == r.scenario.causal_graph
    assert any(v["blueprint_id"] == "vehicle.ford.ambulance" for v in cfg["vehicles"])
    assert cfg["fsm"][0][0][0] == "ambulance1"
    scenic.scenarioFromFile(str(files["scenic"]), mode2D=True)


@pytest.mark.slow
def test_hostile_narrative_is_escaped_in_scenic(tmp_path):
    import scenic

    r = result("stop_abruptly", 2)
    sc = r.scenario.model_copy(update={"narrative": 'x"""\nimport os\nos.system("echo pwned") \\'})
    files = DrivingBackend().export(sc, tmp_path)
    text = files["scenic"].read_text()
    assert "\nimport os" not in text
    scenic.scenarioFromFile(str(files["scenic"]), mode2D=True)


def test_unknown_predicate_in_fsm_is_an_invalid_scenario_verdict():
    from regen.core import FSM, AbstractState, PredicateCall, Stage, StateRef
    from regen.driving.backend import _checked_run
    from regen.driving.ground import ground_rule_based

    sc = ground_rule_based(FEASIBLE["stop_abruptly"][0])
    bad = FSM(states=[AbstractState(name="flying", actor="ego", all_of=[PredicateCall(name="levitates", args=["ego"])])],
              stages=[Stage(conditions=[StateRef(actor="ego", state="flying")])])
    r = _checked_run(DrivingBackend(), sc.model_copy(update={"fsm": bad}), {})
    assert r.verdict.status == "invalid_scenario" and "levitates" in r.verdict.reason
