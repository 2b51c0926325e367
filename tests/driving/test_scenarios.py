"""Done-when: per ego behavior, three or more hand-written chains ground, simulate and verify;
impossible chains are reported with reasons; generated Scenic files compile."""


import pytest
from driving_chains import FEASIBLE, IMPOSSIBLE  # noqa: E402

pytest.importorskip("scenic")

from regen.driving.backend import DrivingBackend  # noqa: E402
from regen.pipeline import ground_stage, run_path  # noqa: E402  (the main job's stages)

CASES = [(k, i) for k, paths in FEASIBLE.items() for i in range(len(paths))]


@pytest.fixture
def result(chain_result):
    """One hand-written chain through the main job's stages (rule-based grounding), once."""
    return chain_result


@pytest.mark.slow
@pytest.mark.parametrize("key,i", CASES)
def test_chain_is_verified(key, i, result):
    r = result(key, i)
    assert r.verdict.status == "verified", r.verdict.reason
    trace, scenario = r.trace(), r.scenario()
    assert trace is not None and set(trace.actors) == {e.name for e in scenario.entities}
    assert trace.meta["map_path"].endswith(".xodr")
    assert scenario.world["grounder"] == "rule-based"


@pytest.mark.slow
def test_each_behavior_has_three_feasible_chains():
    assert all(len(v) >= 3 for v in FEASIBLE.values()) and len(FEASIBLE) == 6


@pytest.mark.slow
def test_ego_stops_before_the_pedestrians_path(result):
    r = result("stop_abruptly", 0)
    tr = r.trace()
    ego, child = tr.actors["ego"], tr.actors["child1"]
    assert ego.speed[-1] < 0.1
    assert ego.x[-1] + ego.length / 2 < child.x[0]  # front bumper short of the crossing line
    assert min(child.y) < -1.75 < max(child.y)  # the child did cross the ego's lane


@pytest.mark.slow
def test_ambulance_ends_in_front_of_the_ego_with_siren_on(result):
    tr = result("stop_abruptly", 1).trace()
    amb, ego = tr.actors["ambulance1"], tr.actors["ego"]
    assert amb.x[0] < ego.x[0] and amb.x[-1] > ego.x[-1] + 5
    assert set(amb.states["siren"]) == {"on"}


@pytest.mark.slow
def test_ego_stops_inside_the_junction_and_red_light_runner_crosses(result):
    tr = result("stop_in_intersection", 0).trace()
    assert tr.actors["ego"].states["in_junction"][-1] is True
    assert any(tr.actors["sedan1"].states["in_junction"])


# A choice of the graph that grounding cannot honor raises UngroundableError: `ungroundable`.
UNGROUNDABLE = ("ungroundable",)


@pytest.mark.parametrize("key,statuses,words", [
    ("slow_lead_brakes", ("unsatisfiable",), "as fast as the ego"),
    ("no_adjacent_lane", UNGROUNDABLE,
     "ambulance1: the graph's start_location = 'behind_adjacent_lane' cannot be honored: the map cannot host"),
    ("contradictory", ("grounding_failed",), "contradictory"),
    ("unsupported_behavior", UNGROUNDABLE, "debris1: the graph's behavior = 'drive_forward' cannot be honored"),
])
def test_impossible_chains_are_recorded_not_raised(key, statuses, words, tmp_path):
    r = run_path(IMPOSSIBLE[key], tmp_path / key)
    assert not r.verdict.feasible and r.verdict.status in statuses
    assert words in r.verdict.reason


@pytest.mark.slow
def test_export_writes_config_and_a_scenic_file_that_compiles(result):
    import json

    import scenic

    from regen.runfolder import ScenarioFolder

    r = result("stop_abruptly", 1)
    folder = ScenarioFolder(r.path)
    cfg = json.loads((folder / folder.SCENARIO).read_text())["config"]
    assert cfg["causal_graph"] == r.scenario().causal_graph
    assert any(v["blueprint_id"] == "vehicle.ford.ambulance" for v in cfg["vehicles"])
    assert cfg["fsm"][0][0][0] == "ambulance1"
    files = folder.files()  # what export returned, as the run folder records it
    assert files["scenic"] == "scenario.scenic" and files["xosc"] == "scenario.xosc"
    scenic.scenarioFromFile(str(folder / files["scenic"]), mode2D=True)


@pytest.mark.slow
def test_hostile_narrative_is_escaped_in_scenic(tmp_path, result):
    import scenic

    r = result("stop_abruptly", 2)
    sc = r.scenario().model_copy(update={"narrative": 'x"""\nimport os\nos.system("echo pwned") \\'})
    files = DrivingBackend().export(sc, tmp_path)
    text = files["scenic"].read_text()
    assert "\nimport os" not in text
    scenic.scenarioFromFile(str(files["scenic"]), mode2D=True)


def test_unknown_predicate_in_fsm_is_an_invalid_scenario_verdict(tmp_path):
    from regen.core import FSM, AbstractState, PredicateCall, Stage, StateRef
    from regen.runfolder import ScenarioFolder

    bad = FSM(states=[AbstractState(name="flying", actor="ego", all_of=[PredicateCall(name="levitates", args=["ego"])])],
              stages=[Stage(conditions=[StateRef(actor="ego", state="flying")])])

    class LevitatingFSM(DrivingBackend):
        def ground(self, path, llm, *, seed=0):
            return super().ground(path, llm, seed=seed).model_copy(update={"fsm": bad})

    folder = ScenarioFolder(tmp_path / "s")
    verdict = ground_stage(LevitatingFSM(), FEASIBLE["stop_abruptly"][0], None, folder)
    assert verdict.status == "invalid_scenario" and "levitates" in verdict.reason
    assert folder.verdict() == verdict and not (folder / folder.TRACE).exists()  # never simulated
