"""Issue 12: the causal graph is the specification, and "verified" means the cause played out.

Grounding (rules or model) gives every entity exactly the behavior, start location, speed class
and property values the graph chose, or says it cannot (``UngroundableError``, naming the
entity, property and value); every driving FSM holds each actor's cause states before the ego's
reaction, so a scenario whose cause never plays out is ``cause_not_shown``, never ``verified``.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the tests folder is not a package
from driving_chains import FEASIBLE, chain  # noqa: E402
from fsm_answers import fsm  # noqa: E402
from test_model import (  # noqa: E402
    CHILD,
    CHILD_FSM,
    CHILD_ROLES,
    RECORDED,
    _llm,
    _recorded_llm,
    _recorded_paths,
    _state,
)

from regen.core import Behavior, CausePath, PathEntity  # noqa: E402
from regen.core.scenario import FSM, AbstractState, PredicateCall  # noqa: E402
from regen.core.trace import ActorTrack, Trace  # noqa: E402
from regen.driving.grounding.fsm_rules import (  # noqa: E402
    cause_states,
    entails,
    is_reaction,
    rule_based_fsm,
    with_cause_states,
)
from regen.driving.grounding.model import ground_with_model  # noqa: E402
from regen.driving.grounding.rules import (  # noqa: E402
    build_scenario,
    ground_rule_based,
    roles_of,
    rule_based_roles,
    template_of,
)
from regen.driving.primitives import is_state_only  # noqa: E402
from regen.driving.world.locations import location_from_text  # noqa: E402
from regen.errors import GroundingError, UngroundableError  # noqa: E402
from regen.llm import LLM  # noqa: E402
from regen.llm.testing import FunctionProvider  # noqa: E402
from regen.verify.monitor import check_fsm  # noqa: E402

CASES = [(k, i) for k, paths in FEASIBLE.items() for i in range(len(paths))]
MOTION = {"behavior", "start_location", "target_speed"}


def _graph_choices(path: CausePath) -> dict[str, dict[str, str]]:
    """Entity name -> what the path's graph chose for it, as grounding names it."""
    out: dict[str, dict[str, str]] = {}
    counts: dict[str, int] = {}
    for pe in path.entities:
        counts[pe.asset] = counts.get(pe.asset, 0) + 1
        chosen = {k: v[0] for k, v in pe.properties.items() if v}
        if "start_location" in chosen:
            chosen["start_location"] = location_from_text(chosen["start_location"]) or chosen["start_location"]
        out[f"{pe.asset}{counts[pe.asset]}"] = chosen
    return out


def _as_grounded(scenario, name: str) -> dict[str, str | None]:
    e = scenario.entity(name)
    return {"behavior": e.behavior, "start_location": e.behavior_params.get("location"),
            "target_speed": e.behavior_params.get("speed_class"), **e.properties}


def assert_honors_the_graph(scenario, path: CausePath) -> None:
    """Every entity has exactly the graph's behavior, start, speed class and property values."""
    for name, chosen in _graph_choices(path).items():
        have = _as_grounded(scenario, name)
        for key, value in chosen.items():
            if key == "behavior" and is_state_only(scenario.entity(name).asset):
                continue  # a light or sensor has no motion primitive
            assert have[key] == value, f"{name}: the graph's {key} = {value!r}, grounded as {have[key]!r}"


def assert_causes_before_the_reaction(scenario) -> None:
    """Each actor has cause states (marked), all in stages before the ego's first reaction."""
    fsm, t = scenario.fsm, template_of(scenario)
    first = next(k for k, st in enumerate(fsm.stages) if any(is_reaction(fsm.state(c.actor, c.state), t)
                                                              for c in st.conditions))
    marked = {(c.actor, c.state) for st in fsm.stages[:first] for c in st.conditions
              if fsm.state(c.actor, c.state).cause}
    for e in scenario.entities[1:]:
        assert any(actor == e.name for actor, _ in marked), f"{e.name} has no cause stage before the reaction"
    for st in fsm.stages[first:]:  # (a cause state may recur later, but is never only there)
        for c in st.conditions:
            if fsm.state(c.actor, c.state).cause:
                assert (c.actor, c.state) in marked


# --- the graph as the specification -----------------------------------------------------------


@pytest.mark.parametrize("key,i", CASES)
def test_rule_grounding_gives_exactly_the_graphs_choices_and_cause_stages(key, i):
    path = FEASIBLE[key][i]
    sc = ground_rule_based(path)
    assert_honors_the_graph(sc, path)
    assert_causes_before_the_reaction(sc)
    # the rule FSM already holds every cause: adding them changes nothing
    assert with_cause_states(sc.fsm, roles_of(sc), template_of(sc)) == (sc.fsm, [])


@pytest.mark.slow
@pytest.mark.parametrize("key,i", CASES)
def test_every_feasible_chain_is_verified_as_the_graph_chose_it(key, i, chain_result):
    r = chain_result(key, i)
    assert r.verdict.status == "verified", r.verdict.reason
    scenario = r.scenario()
    assert_honors_the_graph(scenario, FEASIBLE[key][i])
    assert_causes_before_the_reaction(scenario)
    reached = {lab: st.reached_at for st in r.verdict.stages for lab in st.conditions}
    causes = [f"{s.actor}: {s.name}" for s in scenario.fsm.states if s.cause]
    assert causes and all(reached[c] is not None for c in causes)


def test_the_model_is_asked_only_what_the_graph_left_open():
    open_speed = chain("stop_abruptly", "a child runs across the road", ("child", {
        "behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}))
    llm, provider = _llm(CHILD_ROLES, CHILD_FSM)
    sc = ground_with_model(open_speed, llm)
    assert "Fill in child1_speed, narrative." in provider.requests[0][-1]["content"]
    assert "child1_behavior" not in provider.requests[0][-1]["content"]
    assert_honors_the_graph(sc, open_speed)
    assert sc.entity("child1").behavior_params["speed_class"] == "moderate"  # the model's choice


def test_a_roles_answer_that_changes_the_graphs_behavior_is_refused():
    swapped = dict(CHILD_ROLES, child1_behavior="walk_along")
    llm, provider = _llm(swapped, swapped, swapped, CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    reask = provider.requests[1][-1]["content"]
    assert "child1_behavior: Extra inputs are not permitted" in reask
    assert sc.entity("child1").behavior == "cross_the_road"  # the graph's, never the answer's
    assert sc.world["rule_parts"].startswith("narrative,roles") and sc.fallbacks
    assert_honors_the_graph(sc, CHILD)


def test_roles_that_differ_from_the_graph_are_ungroundable():
    roles = rule_based_roles(CHILD)
    for change, words in ((dict(primitive="walk_along"), "behavior = 'cross_the_road' became 'walk_along'"),
                          (dict(location="crosswalk_ahead"),
                           "start_location = 'roadside_ahead' became 'crosswalk_ahead'")):
        with pytest.raises(UngroundableError, match=f"child1: the graph's {words}"):
            build_scenario(CHILD, [replace(roles[0], **change)], narrative="n", fsm=None, grounder="test")


def test_a_grounder_that_swaps_a_choice_gives_no_scenario(tmp_path):
    from regen.driving.backend import DrivingBackend
    from regen.pipeline import ground_stage
    from regen.runfolder import ScenarioFolder

    class Swapping(DrivingBackend):
        def ground(self, path, llm, *, seed=0):
            roles = [replace(r, primitive="walk_along") for r in rule_based_roles(path)]
            return build_scenario(path, roles, narrative="n", fsm=None, grounder="test", seed=seed)

    verdict = ground_stage(Swapping(), CHILD, None, ScenarioFolder(tmp_path / "s"))
    assert verdict is not None and not verdict.feasible
    assert verdict.status == "ungroundable"
    assert "child1: the graph's behavior = 'cross_the_road' became 'walk_along'" in verdict.reason


# The offline model's graph in the README main job (tests/data/cassettes/generate_driving.json)
# and variants of it: what grounding makes of them, or why it cannot.
OBSERVED_GRAPHS = {
    # "a cyclist is crossing the road": stationary at the crosswalk, with a speed it cannot have
    "cyclist_with_speed": (("bicycle", {"behavior": ["stationary"], "start_location": ["crosswalk_ahead"],
                                        "target_speed": ["slow"]}),
                           "bicycle1: the graph's target_speed = 'slow' cannot be honored"),
    # "a pedestrian steps into the road": crossing, but from the oncoming lane
    "pedestrian_from_the_lane": (("adult", {"behavior": ["cross_the_road"], "start_location": ["oncoming_lane"],
                                            "target_speed": ["slow"]}),
                                 "adult1: the graph's start_location = 'oncoming_lane' cannot be honored: "
                                 "cross_the_road (its behavior in the graph) starts only at"),
    "walking_bicycle": (("bicycle", {"behavior": ["walk_along"]}),
                        "bicycle1: the graph's behavior = 'walk_along' cannot be honored: a bicycle "
                        "supports only"),
    "light_on_the_moon": (("traffic_light", {"light_state": ["turns_red"], "start_location": ["on the moon"]}),
                          "traffic_light1: the graph's start_location = 'on the moon' cannot be honored"),
    # only standing still starts in the ego's lane, and it has no speed
    "running_child_in_the_lane": (("child", {"start_location": ["ahead_same_lane"], "target_speed": ["fast"]}),
                                  "child1: the graph's target_speed = 'fast' cannot be honored: a child that "
                                  "is stationary does not move"),
    "unknown_state": (("ambulance", {"siren": ["howling"]}),
                      "ambulance1: the graph's siren = 'howling' cannot be honored: siren is one of on, off"),
}


@pytest.mark.parametrize("key", sorted(OBSERVED_GRAPHS))
def test_choices_no_grounding_can_honor_are_ungroundable_in_both_grounders(key):
    entity, words = OBSERVED_GRAPHS[key]
    path = chain("stop_abruptly", "something happens", entity)
    with pytest.raises(UngroundableError) as rules:
        ground_rule_based(path)
    assert words in str(rules.value)
    llm, provider = _llm()
    with pytest.raises(UngroundableError) as model:
        ground_with_model(path, llm)
    assert str(model.value) == str(rules.value)
    assert provider.requests == []  # no answer could honor it: the model is not asked


def test_a_cyclist_standing_at_the_crosswalk_is_grounded_as_the_graph_chose():
    path = chain("stop_abruptly", "a cyclist is crossing the road", ("bicycle", {
        "behavior": ["stationary"], "start_location": ["crosswalk_ahead"]}))
    llm, provider = _llm({"narrative": "A cyclist stands on the crosswalk, so the ego stops.",
                          "bicycle1_behavior": "change_lane"},  # the swap observed: refused
                         {"narrative": "A cyclist stands on the crosswalk, so the ego stops."},
                         fsm(_state(1, "ego", "driving", "moving(ego, min_speed=3)"),
                                     _state(2, "bicycle1", "ahead", "in_front(bicycle1, ego)"),
                                     _state(3, "ego", "braking", "braking(ego)")))
    sc = ground_with_model(path, llm)
    assert "Fill in narrative." in provider.requests[0][-1]["content"]  # nothing left to choose
    assert_honors_the_graph(sc, path)
    assert sc.entity("bicycle1").behavior_params["location"] == "crosswalk_ahead"
    # "in front of the ego" does not show it standing in the ego's path: the rules' state is added
    assert sc.fsm.as_tuples() == [[("ego", "driving")], [("bicycle1", "ahead")], [("bicycle1", "in_ego_path")],
                                  [("ego", "braking")]]
    assert sc.fallbacks == ["cause stages added by rules: bicycle1: in_ego_path (same_lane(bicycle1, ego), "
                            "ahead_of(bicycle1, ego), stopped(bicycle1))"]


def test_defaults_fill_only_what_the_graph_left_open():
    # a start without a behavior: a behavior of the asset that starts there
    sc = ground_rule_based(chain("stop_in_intersection", "a car comes from the side", ("sedan", {
        "start_location": ["on the cross street"]})))
    assert sc.entity("sedan1").behavior in ("turn_right", "run_red_light")
    assert sc.entity("sedan1").behavior_params["location"] == "junction_cross_street"
    # a speed without a behavior or start: the defaults, with the graph's speed
    sc = ground_rule_based(chain("slow_down", "a car is ahead", ("sedan", {"target_speed": ["slow"]})))
    assert _as_grounded(sc, "sedan1") == {"behavior": "drive_forward", "start_location": "ahead_same_lane",
                                          "target_speed": "slow"}


# --- cause fidelity ---------------------------------------------------------------------------


def test_a_model_fsm_without_the_cause_gets_the_rules_cause_stage():
    no_cause = fsm(_state(1, "child1", "waiting", "on_sidewalk(child1)"),
                           _state(1, "ego", "driving", "moving(ego, min_speed=3)"),
                           _state(2, "ego", "braking", "braking(ego)"),
                           _state(3, "ego", "stopped", "stopped(ego)"))
    llm, _ = _llm(CHILD_ROLES, no_cause)
    sc = ground_with_model(CHILD, llm)
    assert sc.fsm.as_tuples() == [[("child1", "waiting"), ("ego", "driving")], [("child1", "crossing")],
                                  [("ego", "braking")], [("ego", "stopped")]]
    crossing = sc.fsm.state("child1", "crossing")
    assert crossing.cause and [str(c) for c in crossing.all_of] == [
        "same_lane(child1, ego)", "ahead_of(child1, ego)", "moving(child1, min_speed=0.3)"]
    assert sc.fallbacks == [f"cause stages added by rules: child1: crossing ({', '.join(map(str, crossing.all_of))})"]
    assert sc.world["grounding_notes"] == sc.fallbacks[0]
    assert sc.world["grounder"] == "model" and sc.fsm_source == "model+rules"


def test_a_weaker_or_later_cause_state_of_the_model_does_not_count():
    late = fsm(_state(1, "child1", "waiting", "on_sidewalk(child1)"),
                       _state(1, "ego", "driving", "moving(ego, min_speed=3)"),
                       _state(2, "child1", "on_road", "on_road(child1)", "moving(child1)"),  # weaker
                       _state(3, "ego", "braking", "braking(ego)"),
                       # as strong as the rules', but after the reaction
                       _state(4, "child1", "crossing", "same_lane(child1, ego)", "ahead_of(child1, ego)",
                              "moving(child1)"))
    llm, _ = _llm(CHILD_ROLES, late)
    sc = ground_with_model(CHILD, llm)
    assert sc.fsm.as_tuples() == [[("child1", "waiting"), ("ego", "driving")], [("child1", "on_road")],
                                  [("child1", "crossing_2")], [("ego", "braking")], [("child1", "crossing")]]
    assert sc.fsm.state("child1", "crossing_2").cause and not sc.fsm.state("child1", "on_road").cause


def test_cause_states_keep_their_order_around_the_models_own():
    light = chain("stop_in_intersection", "the light turns red", ("traffic_light", {"light_state": ["turns_red"]}))
    sc = ground_rule_based(light)
    roles, t = roles_of(sc), template_of(sc)
    calls = {"red": [PredicateCall(name="light_is", args=["traffic_light1"], params={"value": "red"})],
             "go": [PredicateCall(name="moving", args=["ego"])],
             "stop": [PredicateCall(name="braking", args=["ego"])]}
    model = FSM.model_validate({
        "states": [AbstractState(name=n, actor="ego" if n != "red" else "traffic_light1", all_of=c).model_dump()
                   for n, c in calls.items()],
        "stages": [{"conditions": [{"actor": "ego", "state": "go"}]},
                   {"conditions": [{"actor": "traffic_light1", "state": "red"}]},
                   {"conditions": [{"actor": "ego", "state": "stop"}]}]})
    fsm, added = with_cause_states(model, roles, t)
    # green (first in the cause) goes first; the model's red counts as the second
    assert fsm.as_tuples() == [[("traffic_light1", "green")], [("ego", "go")], [("traffic_light1", "red")],
                               [("ego", "stop")]]
    assert added == ["traffic_light1: green (light_is(traffic_light1, value=green))"]
    assert fsm.state("traffic_light1", "red").cause and not fsm.state("ego", "go").cause


def test_entailment_compares_thresholds_in_the_right_direction():
    def st(*calls: PredicateCall) -> AbstractState:
        return AbstractState(name="s", actor="a", all_of=list(calls))

    def call(name, *args, negate=False, **params):
        return PredicateCall(name=name, args=list(args), params=params, negate=negate)

    assert entails(st(call("moving", "a", min_speed=1.0)), st(call("moving", "a", min_speed=0.3)))
    assert not entails(st(call("moving", "a", min_speed=0.2)), st(call("moving", "a", min_speed=0.3)))
    assert entails(st(call("moving", "a")), st(call("moving", "a", min_speed=0.3)))  # default 0.5
    assert entails(st(call("in_front", "a", "ego", distance=20.0)), st(call("in_front", "a", "ego", distance=40.0)))
    assert not entails(st(call("in_front", "a", "ego")), st(call("in_front", "a", "ego", distance=20.0)))
    assert entails(st(call("moving", "a", negate=True, min_speed=0.3)),
                   st(call("moving", "a", negate=True, min_speed=0.5)))
    assert not entails(st(call("moving", "a", negate=True)), st(call("moving", "a")))
    assert not entails(st(call("light_is", "a", value="green")), st(call("light_is", "a", value="red")))
    assert not entails(st(call("ahead_of", "a", "ego")), st(call("ahead_of", "a", "ego"), call("same_lane", "a", "ego")))


def _trace(child_y: list[float], child_speed: float) -> Trace:
    """The ego drives at 10 m/s, brakes at t=3 s and stops; the child 30 m ahead of its start."""
    n, dt = 60, 0.1
    speed = [10.0 if k < 30 else max(0.0, 10.0 - 6.0 * (k - 30) * dt) for k in range(n)]
    x = [0.0]
    for v in speed[:-1]:
        x.append(x[-1] + v * dt)
    on_road = [abs(y) < 7.0 for y in child_y]
    return Trace(dt=dt, times=[k * dt for k in range(n)], actors={
        "ego": ActorTrack(asset="ego", kind="ego", length=4.6, width=1.9, x=x, y=[-1.75] * n, heading=[0.0] * n,
                          speed=speed),
        "child1": ActorTrack(asset="child", length=0.5, width=0.5, x=[30.0] * n, y=child_y, heading=[1.57] * n,
                             speed=[child_speed] * n,
                             states={"on_road": on_road, "on_sidewalk": [not r for r in on_road],
                                     "in_junction": [False] * n, "lane": [0 if r else None for r in on_road]})})


@pytest.mark.parametrize("child_y,speed,why", [
    ([-8.0] * 60, 0.0, "it never leaves the sidewalk"),
    ([-8.0] * 10 + [1.75] * 50, 1.2, "it walks in the oncoming lane: on the road, moving, ahead, not in the ego's lane"),
])
def test_a_cause_actor_that_never_crosses_is_cause_not_shown(child_y, speed, why):
    sc = ground_rule_based(CHILD)
    verdict = check_fsm(sc, _trace(child_y, speed))
    assert verdict.status == "cause_not_shown", why
    assert "child1: crossing" in verdict.reason and verdict.first_unmet_stage == 2


def test_a_crossing_in_the_ego_lane_shows_the_cause():
    crossing = [-8.0] * 10 + [-8.0 + 0.3 * k for k in range(50)]  # through the ego's lane by t=2.8 s
    verdict = check_fsm(ground_rule_based(CHILD), _trace(crossing, 1.2))
    assert verdict.stages[1].conditions == ["child1: crossing"] and verdict.stages[1].reached_at is not None


def test_every_actor_of_a_path_gets_cause_states():
    two = CausePath(behavior=Behavior(text="the ego-vehicle stops abruptly", domain="driving",
                                      params={"ego_template": "stop_abruptly"}),
                    events=["a car brakes while an ambulance approaches", "the ego-vehicle stops abruptly"],
                    entities=[PathEntity(asset="sedan", event="x", properties={
                                  "behavior": ["drive_forward"], "start_location": ["ahead_same_lane"]}),
                              PathEntity(asset="ambulance", event="x", properties={
                                  "siren": ["on"], "start_location": ["behind_adjacent_lane"]})])
    sc = ground_rule_based(two)
    assert {s.actor for s in cause_states(roles_of(sc), template_of(sc))} == {"sedan1", "ambulance1"}
    assert_causes_before_the_reaction(sc)
    assert all(any(c.name == "siren_on" for c in s.all_of) for s in sc.fsm.states if s.actor == "ambulance1")


def test_the_rule_fsm_has_cause_states_marked():
    fsm = rule_based_fsm(roles_of(ground_rule_based(CHILD)), template_of(ground_rule_based(CHILD)))
    assert [s.name for s in fsm.states if s.cause] == ["crossing"]


# --- the recorded offline-model answers ---------------------------------------------------------

# Recorded with the roles schema that let the model choose everything; the graph's choices are
# no longer asked, so the keys of these roles calls are not in the cassette any more.
# The recording was made again after the roles call stopped asking what the graph fixed, so every
# recorded roles answer replays; none is refused any more.
NO_LONGER_REPLAYED: tuple[str, ...] = ()


def test_recorded_red_light_answers_still_replay_and_honor_the_graph():
    path = _recorded_paths()["red_light"]
    llm = _recorded_llm()
    sc = ground_with_model(path, llm)
    assert llm.stats.total.model_calls == 0 and llm.stats.total.cache_hits == 2
    assert_honors_the_graph(sc, path)
    assert sc.world["model_parts"] == "narrative,roles,fsm" and sc.fsm_source == "model+rules"
    # its own state (named "light_is") is the light red; the rules add the green before it
    assert sc.fsm.state("traffic_light1", "light_is").cause
    assert sc.fallbacks == ["cause stages added by rules: traffic_light1: green (light_is(traffic_light1, "
                            "value=green))"]
    assert sc.fsm.as_tuples() == [[("traffic_light1", "green")], [("traffic_light1", "light_is"), ("ego", "driving")],
                                  [("ego", "stop")]]


def _recorded_answers(key: str) -> LLM:
    """A model that gives the path's recorded answers (its first roles and FSM answer, each
    time it is asked), whatever the key of the call."""
    per_path: list[dict[str, str]] = []
    for entry in json.loads(RECORDED.read_text()):  # recorded path by path, the roles call first
        if entry["purpose"] == "ground_roles":
            per_path.append({})
        per_path[-1].setdefault(entry["purpose"], entry["response"])
    answers = dict(zip(_recorded_paths(), per_path, strict=True))[key]
    return LLM(FunctionProvider(lambda messages: answers["ground_roles" if "Fill in" in messages[1]["content"]
                                                         else "ground_fsm"]))


@pytest.mark.parametrize("key", ["jaywalker", "ambulance", "red_light"])
def test_recorded_answers_give_the_graphs_entities(key):
    """The recorded answers, fed in order: the roles that chose a graph-fixed behavior or start
    are refused (the rules' roles, which are the graph's, replace them), the rest is used."""
    path = _recorded_paths()[key]
    sc = ground_with_model(path, _recorded_answers(key))
    assert_honors_the_graph(sc, path)
    assert_causes_before_the_reaction(sc)
    if key in NO_LONGER_REPLAYED:  # it answered change_lane / crosswalk_ahead for a graph that said otherwise
        assert sc.world["rule_parts"].startswith("narrative,roles")
        assert any("Extra inputs are not permitted" in f for f in sc.fallbacks)


@pytest.mark.slow
@pytest.mark.parametrize("key", ["jaywalker", "ambulance", "red_light"])
def test_recorded_answers_simulate_as_the_graph_chose_or_say_why_not(key, tmp_path):
    pytest.importorskip("scenic")
    from regen.pipeline import run_path

    path = _recorded_paths()[key]
    r = run_path(path, tmp_path / key, llm=_recorded_answers(key), pictures=False)
    scenario = r.scenario()
    assert_honors_the_graph(scenario, path)
    if r.verdict.feasible:
        assert_causes_before_the_reaction(scenario)
    else:  # the model's own FSM wants the ego at 5 m/s or more and slower than 5 m/s at once
        assert key == "ambulance" and r.verdict.status == "fsm_incomplete"
        assert "ego: braking" in r.verdict.reason


def test_a_path_the_rules_cannot_place_raises_before_any_model_call():
    llm, provider = _llm()
    with pytest.raises(GroundingError, match="cannot host"):
        ground_with_model(chain("stop_in_intersection", "an ambulance overtakes", ("ambulance", {
            "behavior": ["drive_forward"], "start_location": ["behind_adjacent_lane"]})), llm)
    assert provider.requests == []
