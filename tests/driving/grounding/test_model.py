"""Model grounding of driving paths: queued answers (fast) and one simulated run (slow)."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest
from driving_chains import FEASIBLE, IMPOSSIBLE, chain  # noqa: E402
from fsm_answers import fsm  # noqa: E402
from fsm_answers import state as _state  # noqa: E402

from regen.driving.backend import DrivingBackend  # noqa: E402
from regen.driving.grounding.answers import fsm_schema, parse_call  # noqa: E402
from regen.driving.grounding.feasibility import never_holds  # noqa: E402
from regen.driving.grounding.fsm_rules import rule_based_fsm  # noqa: E402
from regen.driving.grounding.model import ground_with_model  # noqa: E402
from regen.driving.grounding.rules import ground_rule_based, roles_of, template_of  # noqa: E402
from regen.driving.simulation.scenario import scenic_program  # noqa: E402
from regen.errors import (  # noqa: E402
    CacheMissError,
    GroundingError,
    ProviderUnreachableError,
    UngroundableError,
)
from regen.llm import LLM  # noqa: E402
from regen.llm.testing import QueuedProvider  # noqa: E402
from regen.verify.predicates import list_predicates  # noqa: E402

CHILD = FEASIBLE["stop_abruptly"][0]  # a child runs across the road
AMBULANCE = FEASIBLE["stop_abruptly"][1]  # an ambulance with its siren on approaches from behind
RED_LIGHT = FEASIBLE["stop_in_intersection"][0]  # a car runs the red light

# the graph chose the child's behavior and start: the model only tells the story and the speed
CHILD_ROLES = {"narrative": "A child runs across the road from the sidewalk, so the ego brakes hard.",
               "child1_speed": "moderate"}
# a child the graph says nothing about: the model chooses its behavior, start and speed
OPEN_CHILD = chain("stop_abruptly", "a child runs across the road", ("child", {}))




CHILD_FSM = fsm(
    _state(1, "child1", "waiting", "on_sidewalk(child1)"),
    _state(1, "ego", "driving", "moving(ego, min_speed=3)"),
    # gap: 3 becomes 2; it shows the cause (moving in the ego's lane ahead), so none is added
    _state(3, "child1", "crossing", "same_lane(child1, ego)", "ahead_of(child1, ego)", "moving(child1)"),
    _state(4, "ego", "braking", "braking(ego)"),
    _state(5, "ego", "stopped", "stopped(ego)", "not in_front(child1, ego, distance=2)"),
)


def _llm(*answers) -> tuple[LLM, QueuedProvider]:
    provider = QueuedProvider(list(answers))
    return LLM(provider), provider


def test_good_answer_grounds_into_the_models_scenario():
    llm, provider = _llm(CHILD_ROLES, CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    assert sc.world["grounder"] == "model"
    assert sc.world["model_parts"] == "narrative,roles,fsm" and sc.world["rule_parts"] == ""
    assert sc.narrative == CHILD_ROLES["narrative"]
    assert sc.fsm.as_tuples() == [[("child1", "waiting"), ("ego", "driving")], [("child1", "crossing")],
                                  [("ego", "braking")], [("ego", "stopped")]]
    stopped = sc.fsm.state("ego", "stopped").all_of
    assert stopped[1].negate and stopped[1].args == ["child1", "ego"] and stopped[1].params == {"distance": 2.0}
    assert sc.fsm.state("ego", "driving").all_of[0].params == {"min_speed": 3.0}
    assert sc.entity("child1").behavior == "cross_the_road"
    assert sc.solver.status in ("optimal", "feasible") and sc.solver.relaxations == [] and sc.fallbacks == []
    assert sc.fsm_source == "model" and sc.fsm.state("child1", "crossing").cause
    assert len(sc.world["model_calls"].split(",")) == 2
    # the roles call asks only what the graph left open: the speed
    assert "Fill in child1_speed, narrative." in provider.requests[0][-1]["content"]
    # the FSM prompt names only this scenario's actors and leaves out impossible predicates
    fsm_prompt = provider.requests[1][-1]["content"]
    assert "child1: child, cross the road from roadside_ahead" in fsm_prompt
    # and how its part in the cause shows (the rules' cause state), so the model can write it
    assert ("its part in the cause shows as: same_lane(child1, ego) and ahead_of(child1, ego) and "
            "moving(child1, min_speed=0.3)") in fsm_prompt
    assert "siren_on" not in fsm_prompt and "light_is" not in fsm_prompt


def test_model_roles_change_the_placement():
    roles = dict(CHILD_ROLES, child1_behavior="cross_the_road", child1_start="roadside_opposite_ahead",
                 child1_speed="fast")
    llm, _ = _llm(roles, CHILD_FSM)
    sc = ground_with_model(OPEN_CHILD, llm)
    rule = ground_rule_based(OPEN_CHILD)
    assert sc.entity("child1").behavior_params["location"] == "roadside_opposite_ahead"
    assert rule.entity("child1").behavior_params["location"] == "roadside_ahead"
    assert sc.parameters["child1"] != rule.parameters["child1"]


def test_unknown_actor_and_predicate_are_reasked_then_accepted():
    bad = fsm(_state(1, "ambulance1", "behind", "behind(ambulance1, ego)"),
                      _state(2, "ego", "flying", "levitates(ego)"))
    llm, provider = _llm(CHILD_ROLES, bad, CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    assert sc.world["grounder"] == "model"
    reask = provider.requests[2][-1]["content"]
    # the errors went back to the model: an unknown actor, an actor left out, an unknown predicate
    assert "states.ambulance1: Extra inputs are not permitted" in reask
    assert "states.child1: Field required" in reask and "levitates" in reask
    assert llm.stats.by_purpose["ground_fsm"].reasks == 1


def test_fsm_that_stays_invalid_falls_back_to_the_rules_with_the_reason():
    bad = fsm(_state(1, "child1", "w", "on_sidewalk(child1)"),
                      _state(2, "ego", "flying", "levitates(ego)"))
    llm, _ = _llm(CHILD_ROLES, bad, bad, bad)
    sc = ground_with_model(CHILD, llm)
    assert sc.world["grounder"] == "model+rules"
    assert sc.world["model_parts"] == "narrative,roles" and sc.world["rule_parts"] == "fsm"
    assert sc.fsm == rule_based_fsm(roles_of(sc), template_of(sc))
    assert "levitates" in sc.world["grounding_notes"]
    assert any("ground_fsm" in r and "used the rules" in r for r in sc.fallbacks)
    assert sc.solver.relaxations == []  # a model fallback is not a placement relaxation


def test_after_a_failed_fsm_schema_the_same_client_uses_the_rules_without_asking():
    bad = fsm(_state(1, "child1", "w", "on_sidewalk(child1)"),
                      _state(2, "ego", "driving", "moving(ego, min_speed=10)"))  # it drives at most 10 m/s
    llm, provider = _llm(CHILD_ROLES, bad, bad, bad, {"narrative": "An ambulance overtakes with its siren on."})
    first = ground_with_model(CHILD, llm)
    assert first.world["rule_parts"] == "fsm" and llm.stats.by_purpose["ground_fsm"].calls == 3
    second = ground_with_model(AMBULANCE, llm)  # the roles call only
    assert len(provider.requests) == 5 and llm.stats.by_purpose["ground_fsm"].calls == 3
    assert second.world["rule_parts"] == "fsm" and second.fsm == rule_based_fsm(roles_of(second),
                                                                                template_of(second))
    assert second.fallbacks == [f"ground_fsm: not asked, the model failed its schema earlier with this client "
                                f"(scenario {first.id}); used the rules"]
    llm, _ = _llm(CHILD_ROLES, CHILD_FSM)  # another client asks again
    assert ground_with_model(CHILD, llm).world["model_parts"] == "narrative,roles,fsm"


def test_unknown_behavior_and_extra_actor_are_reasked_then_fall_back():
    bad = dict(CHILD_ROLES, child1_behavior="fly", dragon1_behavior="drive_forward")
    llm, provider = _llm(bad, bad, bad, CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    assert sc.world["grounder"] == "model+rules"
    assert sc.world["rule_parts"] == "narrative,roles" and sc.world["model_parts"] == "fsm"
    assert sc.narrative == "a child runs across the road, so the ego-vehicle stops abruptly while driving forward."
    reask = provider.requests[1][-1]["content"]
    assert "child1_behavior" in reask and "dragon1_behavior" in reask
    assert "child1_behavior" in sc.world["grounding_notes"]


def test_malformed_answers_fall_back_to_rules_entirely():
    llm, _ = _llm("I think the child", "{not json", "", "sorry", "[]", "{}")
    sc = ground_with_model(CHILD, llm)
    rule = ground_rule_based(CHILD)
    assert sc.world["grounder"] == "rule-based" and sc.world["model_parts"] == ""
    assert sc.fsm == rule.fsm and sc.parameters == rule.parameters
    assert len(sc.fallbacks) == 2 and sc.solver.relaxations == [] and sc.world["model_calls"] == ""


def test_start_that_does_not_suit_the_behavior_is_reasked():
    good = dict(CHILD_ROLES, child1_behavior="cross_the_road", child1_start="roadside_ahead")
    bad = dict(good, child1_behavior="walk_along", child1_start="crosswalk_ahead")
    llm, provider = _llm(bad, good, CHILD_FSM)
    sc = ground_with_model(OPEN_CHILD, llm)
    assert sc.world["grounder"] == "model"
    assert "walk_along starts at: roadside_ahead, roadside_opposite_ahead" in provider.requests[1][-1]["content"]


def test_locations_the_map_cannot_host_are_not_offered():
    # stop_in_intersection runs on a one-lane junction road: no adjacent lane exists
    car = chain("stop_in_intersection", "a car crosses", ("sedan", {}))
    llm, provider = _llm("{}", "{}", "{}", "{}", "{}", "{}")
    ground_with_model(car, llm)
    schema = provider.requests[0]
    prompt = schema[-1]["content"]
    assert "junction_cross_street" in prompt and "behind_adjacent_lane" not in prompt
    bad = {"narrative": "A car runs the red light.", "sedan1_behavior": "drive_forward",
           "sedan1_start": "behind_adjacent_lane", "sedan1_speed": "fast"}
    llm, provider = _llm(bad, bad, bad, "{}", "{}", "{}")
    sc = ground_with_model(car, llm)
    reask = provider.requests[1][-1]["content"]
    assert "sedan1_start: Input should be" in reask and "behind_adjacent_lane" not in reask
    assert sc.entity("sedan1").behavior == "drive_forward"  # the rule-based role


def test_a_model_speed_class_without_a_placement_is_refit_and_said_so():
    # a slow lead that must brake ahead of the ego has no placement; the path leaves the speed open,
    # so the nearest class that fits (moderate) replaces the model's, recorded as a fallback
    lead = chain("stop_abruptly", "the car in front brakes hard", ("sedan", {
        "behavior": ["brake_ahead"], "start_location": ["ahead_same_lane"]}))
    roles = {"narrative": "The car in front brakes hard.", "sedan1_speed": "slow"}
    answer = fsm(_state(1, "sedan1", "leading", "in_front(sedan1, ego, distance=60)"),
                 _state(2, "ego", "stopped", "stopped(ego)"))
    llm, _ = _llm(roles, answer)
    sc = ground_with_model(lead, llm)
    assert sc.solver.status in ("optimal", "feasible")
    assert sc.entity("sedan1").behavior_params["speed_class"] == "moderate"
    assert sc.world["grounder"] == "model"  # the model's roles, one speed class refit
    (note,) = [f for f in sc.fallbacks if "speed class" in f]
    assert "sedan1 slow -> moderate" in note and "drives at least as fast as the ego" in note


def test_a_state_whose_calls_contradict_each_other_is_reasked():
    # recorded from the offline model: the ego "braking" at 5 m/s or more and below 5 m/s at once
    bad = fsm(_state(1, "child1", "crossing", "on_road(child1)"),
              _state(2, "ego", "braking", "moving(ego, min_speed=5)", "slower_than(ego, max_speed=5.0)"))
    worse = fsm(_state(1, "child1", "crossing", "on_road(child1)", "not on_road(child1)"),
                _state(2, "ego", "near", "close_to(child1, ego, distance=5)", "far_from(ego, child1, distance=20)"))
    llm, provider = _llm(CHILD_ROLES, bad, worse, CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    first, second = provider.requests[2][-1]["content"], provider.requests[3][-1]["content"]
    assert ("moving(ego, min_speed=5.0) (faster than 5 m/s) and slower_than(ego, max_speed=5.0) (slower than "
            "5 m/s) cannot hold at once") in first
    assert "on_road(child1) and its negation cannot hold at once" in second
    assert "(within 5 m) and far_from(ego, child1, distance=20.0) (more than 20 m) cannot hold at once" in second
    assert sc.world["model_parts"] == "narrative,roles,fsm"


def test_a_light_asked_to_show_two_colours_at_once_is_reasked():
    light = chain("stop_in_intersection", "the light turns red", ("traffic_light", {"light_state": ["turns_red"]}))
    both = fsm(_state(1, "traffic_light1", "changing", "light_is(traffic_light1, value=green)",
                      "light_is(traffic_light1, value=red)"),
               _state(2, "ego", "stopping", "braking(ego)"))
    good = fsm(_state(1, "traffic_light1", "red", "light_is(traffic_light1, value=red)"),
               _state(2, "ego", "stopping", "braking(ego)"))
    llm, provider = _llm({"narrative": "The light turns red; the ego stops."}, both, good)
    sc = ground_with_model(light, llm)
    assert ("light_is(traffic_light1, value=green) and light_is(traffic_light1, value=red) cannot hold at "
            "once") in provider.requests[2][-1]["content"]
    # the prompt names only the light's last cause state (red); the rules add the green before it
    assert "its part in the cause shows as: light_is(traffic_light1, value=red)\n" in provider.requests[1][-1]["content"]
    assert sc.world["model_parts"] == "narrative,roles,fsm" and sc.fsm.state("traffic_light1", "red").cause


def test_fsm_that_can_never_hold_is_reasked():
    roles = {"narrative": "An ambulance with its siren on overtakes the ego."}  # the graph chose the rest
    bad = fsm(_state(1, "ambulance1", "passing", "behind(ambulance1, ego)", "changing_lane(ambulance1)"),
                      _state(2, "ego", "yielding", "siren_on(ego)"))
    good = fsm(_state(1, "ambulance1", "approaching", "behind(ambulance1, ego)", "siren_on(ambulance1)"),
                       _state(2, "ego", "braking", "braking(ego, min_decel=4)"),
                       _state(3, "ambulance1", "passed", "ahead_of(ambulance1, ego)"))
    llm, provider = _llm(roles, bad, good)
    sc = ground_with_model(AMBULANCE, llm)
    reask = provider.requests[2][-1]["content"]
    assert "siren_on(ego) never holds" in reask
    assert "'changing_lane' is not a predicate of this scenario" in reask  # nobody changes lanes
    assert sc.world["grounder"] == "model"
    # the model's states, and the rules' cause state (closing in, in the next lane, siren on)
    assert [s.name for s in sc.fsm.states] == ["approaching", "passed", "braking", "close_behind"]
    assert sc.fsm.as_tuples()[1:3] == [[("ambulance1", "close_behind")], [("ego", "braking")]]
    assert sc.fsm_source == "model+rules" and sc.fallbacks[0].startswith("cause stages added by rules: ")


def test_a_state_name_that_claims_more_than_its_calls_is_renamed_and_noted():
    roles = {"narrative": "An ambulance with its siren on overtakes the ego."}
    claims = fsm(_state(1, "ambulance1", "approaching", "behind(ambulance1, ego)", "siren_on(ambulance1)"),
                 _state(2, "ego", "braking", "braking(ego, min_decel=4)"),
                 _state(3, "ambulance1", "crashed_into_ego", "ahead_of(ambulance1, ego)"),
                 _state(3, "ego", "not_colliding", "slower_than(ego, max_speed=5)"))
    llm, _ = _llm(roles, claims)
    sc = ground_with_model(AMBULANCE, llm)
    names = [s.name for s in sc.fsm.states]
    # nothing collided: the name says so no more; a braking state that brakes keeps its name,
    # and a name that denies a collision claims none
    assert "crashed_into_ego" not in names and {"ahead_of_ego", "braking", "not_colliding"} <= set(names)
    assert ("ambulance1", "ahead_of_ego") in {p for stage in sc.fsm.as_tuples() for p in stage}
    note = next(f for f in sc.fallbacks if f.startswith("state names replaced by rules: "))
    assert "'crashed_into_ego' renamed 'ahead_of_ego' (the name claims a collision" in note
    assert "not_colliding" not in note


def test_hostile_narrative_is_kept_as_data_and_escaped_in_scenic():
    hostile = 'x"""\nimport os\nos.system("rm -rf /") # {{ evil }} \\'
    llm, _ = _llm(dict(CHILD_ROLES, narrative=hostile), CHILD_FSM)
    sc = ground_with_model(CHILD, llm)
    assert sc.narrative == " ".join(hostile.split())
    program = scenic_program(sc)
    line = next(x for x in program.splitlines() if x.startswith("param regen_narrative = "))
    assert ast.literal_eval(line.removeprefix("param regen_narrative = ")) == sc.narrative  # one literal
    assert "\nimport os" not in program and "\nos.system" not in program


def test_backend_uses_the_model_grounder():
    llm, _ = _llm(CHILD_ROLES, CHILD_FSM)
    sc = DrivingBackend().ground(CHILD, llm)
    assert sc.world["grounder"] == "model" and sc.world["llm"] == "queued:test"


def test_broken_paths_raise_grounding_errors_without_calling_the_model():
    llm, provider = _llm()
    for key in ("contradictory",):
        with pytest.raises(GroundingError, match="contradictory"):
            ground_with_model(IMPOSSIBLE[key], llm)
    with pytest.raises(GroundingError, match="not in the driving database"):
        ground_with_model(chain("stop_abruptly", "a dragon lands", ("dragon", {})), llm)
    assert provider.requests == []


def test_replay_cache_miss_propagates_instead_of_falling_back():
    from regen.llm.cache import CallCache

    llm = LLM("local", cache=CallCache(None), replay=True)  # replay with an empty cache
    with pytest.raises(CacheMissError, match="replay mode"):
        ground_with_model(CHILD, llm)


def test_provider_errors_propagate_after_a_good_first_answer():
    from regen.llm.testing import FunctionProvider

    def answer(messages):
        if "Fill in" in messages[-1]["content"]:
            return CHILD_ROLES
        raise ProviderUnreachableError("the provider is down")

    with pytest.raises(ProviderUnreachableError, match="down"):
        ground_with_model(CHILD, LLM(FunctionProvider(answer)))


def test_unplaceable_location_text_is_ungroundable_in_both_grounders():
    path = chain("stop_abruptly", "a child runs out", ("child", {"start_location": ["on the moon"]}))
    with pytest.raises(UngroundableError, match="child1: the graph's start_location = 'on the moon'"):
        ground_rule_based(path)
    llm, provider = _llm(CHILD_ROLES, CHILD_FSM)
    with pytest.raises(UngroundableError, match="on the moon"):
        ground_with_model(path, llm)
    assert provider.requests == []  # no answer could honor it: the model is not asked


# --- the pieces ---------------------------------------------------------------------------------


def _specs():
    return {s.name: s for s in list_predicates("driving")}


@pytest.mark.parametrize("text,problem", [
    ("flies(ego)", "not a predicate of this scenario"),
    ("moving(ego, child1)", "takes 1 actor"),
    ("behind(ego)", "takes 2 actor"),
    ("behind(ego, ego)", "with itself"),
    ("moving(bob)", "unknown actor"),
    ("moving(ego, speed=3)", "no parameter 'speed'"),
    ("moving(ego, min_speed=999)", "between 0 and 200"),
    ("light_is(ego, value=purple)", "red, yellow, green, off"),
    ("__import__('os')", "not a predicate call"),
])
def test_parse_call_rejects_with_a_message(text, problem):
    with pytest.raises(ValueError, match=problem.replace("(", r"\(")):
        parse_call(text, _specs(), ["ego", "child1"])


def test_parse_call_reads_negation_and_parameters():
    c = parse_call("not  close_to(child1, ego, distance=12.5)", _specs(), ["ego", "child1"])
    assert (c.negate, c.name, c.args, c.params) == (True, "close_to", ["child1", "ego"], {"distance": 12.5})


def test_never_holds_knows_primitives_properties_and_maps():
    base = ground_rule_based(AMBULANCE)  # siren on, drives forward, straight road
    roles = {r.name: r for r in roles_of(base)}
    t = template_of(base)
    specs = _specs()

    def why(text):
        return never_holds(parse_call(text, specs, ["ego", "ambulance1"]), roles, t)

    assert why("siren_on(ambulance1)") is None and why("moving(ambulance1)") is None
    assert "no junction" in why("in_junction(ambulance1)")
    assert "keeps its line" in why("changing_lane(ambulance1)")
    assert "door stays closed" in why("door_open(ambulance1)")
    assert why("stopped(ego)") is None and "ego" in why("turning(ego)")
    assert why("not turning(ego)") is None  # a negated impossibility always holds
    assert "at most 10 m/s" in why("moving(ego, min_speed=10)") and why("moving(ego, min_speed=9)") is None
    assert "at most 18 m/s" in why("moving(ambulance1, min_speed=20)")  # fast: 12-18 m/s
    light = ground_rule_based(FEASIBLE["drive_forward"][0])  # red, then green
    lroles = {r.name: r for r in roles_of(light)}
    lt = template_of(light)
    call = parse_call("light_is(traffic_light1, value=yellow)", specs, ["ego", "traffic_light1"])
    assert "shows green, red" in never_holds(call, lroles, lt)
    assert never_holds(parse_call("light_is(traffic_light1, value=green)", specs, ["ego", "traffic_light1"]),
                       lroles, lt) is None
    assert "does not move" in never_holds(parse_call("moving(traffic_light1)", specs,
                                                     ["ego", "traffic_light1"]), lroles, lt)


def test_fsm_schema_constrains_names_for_constrained_decoding():
    base = ground_rule_based(CHILD)
    schema = fsm_schema(roles_of(base), template_of(base)).model_json_schema()
    per_actor = schema["$defs"]["ActorStates"]
    # every actor is a required key, the causes first and the ego last: none can be left out
    assert per_actor["required"] == ["child1", "ego"] and per_actor["additionalProperties"] is False
    assert per_actor["properties"]["child1"]["minItems"] == 1 and per_actor["properties"]["ego"]["maxItems"] == 3
    state = schema["$defs"]["State_ego"]["properties"]
    assert state["stage"]["enum"] == [1, 2, 3, 4, 5, 6]
    import re

    rx = re.compile(state["holds"]["items"]["pattern"])
    child = re.compile(schema["$defs"]["State_child1"]["properties"]["holds"]["items"]["pattern"])
    assert child.match("on_road(child1)") and child.match("not in_front(child1, ego, distance=2)")
    assert rx.match("not in_front(child1, ego, distance=2)")  # a call about both actors
    # a state's calls name its actor
    assert not rx.match("on_road(child1)") and not child.match("moving(ego)")
    assert not child.match("siren_on(child1)") and not rx.match("moving(bob)")
    assert rx.match("moving(ego, min_speed=2.5)") and not rx.match("moving(ego, speed=2.5)")
    assert not rx.match("behind(ego)") and not rx.match("moving(ego, child1)")
    # what the validator would reject cannot be written at all (no answer thrown away for it):
    # a speed the actor never reaches, an actor compared with itself, a motion of a non-mover
    top = max([template_of(base).speed0] + [v for _, v, _ in template_of(base).schedule])
    assert rx.match(f"moving(ego, min_speed={int(top) - 1})")
    assert not rx.match(f"moving(ego, min_speed={int(top)})") and not rx.match("moving(ego, min_speed=150)")
    assert not child.match("in_front(child1, child1)") and not child.match("turning(child1)")
    assert not child.match("in_front(child1, ego, distance=250)")


def test_fsm_schema_offers_only_the_light_values_the_light_shows():
    light = ground_rule_based(chain("stop_in_intersection", "the light turns red",
                                    ("traffic_light", {"light_state": ["turns_red"]})))
    schema = fsm_schema(roles_of(light), template_of(light)).model_json_schema()
    import re

    rx = re.compile(schema["$defs"]["State_traffic_light1"]["properties"]["holds"]["items"]["pattern"])
    assert rx.match("light_is(traffic_light1, value=red)") and rx.match("light_is(traffic_light1, value=green)")
    assert not rx.match("light_is(traffic_light1, value=off)")  # it never shows off
    assert not rx.match("light_is(traffic_light1)")  # the value is what the state is about


# --- through simulation ----------------------------------------------------------------------


@pytest.mark.slow
def test_over_strict_model_stage_is_relaxed_after_simulation(tmp_path):
    pytest.importorskip("scenic")
    from regen.pipeline import run_path

    strict = fsm(
        _state(1, "child1", "waiting", "on_sidewalk(child1)"),
        _state(2, "child1", "crossing", "on_road(child1)", "moving(child1)"),
        # the model wants the ego to brake while the child is already on the far sidewalk
        _state(3, "ego", "braking", "braking(ego)"),
        _state(3, "child1", "crossed", "on_sidewalk(child1)"),
    )
    llm, _ = _llm(CHILD_ROLES, strict)
    r = run_path(CHILD, tmp_path / "child", llm=llm, pictures=False)
    scenario = r.scenario()  # the scenario folder holds the FSM the verdict judged
    assert scenario.world["grounder"] == "model"
    assert r.verdict.status == "verified_after_relaxation", r.verdict.reason
    assert any("relaxed into 2 consecutive stages" in x for x in r.verdict.relaxations)
    # "on the road" does not show the crossing: the rules' cause stage comes before the braking
    assert scenario.fsm_source == "model+rules" and scenario.fsm.state("child1", "crossing_2").cause
    assert scenario.fsm.as_tuples()[2:] == [[("child1", "crossing_2")], [("ego", "braking")], [("child1", "crossed")]]
    stage = r.verdict.stages[3]  # braking (t ~ 6 s) comes before the far sidewalk (t ~ 13 s)
    assert stage.conditions == ["ego: braking"] and 5.5 < stage.reached_at < 7.5


# --- recorded answers of the offline model (scripts/record_cassettes.py ground) ---------------

CASSETTES = Path(__file__).resolve().parents[2] / "data" / "cassettes"
RECORDED = CASSETTES / "ground_driving.json"
RECORDED_PATHS = CASSETTES / "ground_driving_paths.json"
# What the offline model (Qwen2.5-Coder-1.5B, Q4_K_M) answered, as observed when recording:
# key -> (grounder, model parts, verdict status). Every FSM answer validates at once (the schema
# has a required list per actor and only admits calls that can hold; the prompt names each
# actor's cause state). The jaywalker's FSM has its cause state; the light's lacks the green
# before red and the ambulance's its closing in, which the rules add; the ambulance's FSM also
# asks it to be in the ego's lane within 40 m after the ego changed lanes, which never happens:
# that state is dropped, and the verdict says so.
OBSERVED: dict[str, tuple[str, str, str]] = {
    "jaywalker": ("model", "narrative,roles,fsm", "verified"),
    "ambulance": ("model", "narrative,roles,fsm", "verified_after_relaxation"),
    "red_light": ("model", "narrative,roles,fsm", "verified"),
}


def _recorded_llm() -> LLM:
    from regen.llm.cache import CallCache

    cache = CallCache(None)
    cache.import_json(RECORDED)
    return LLM("local", cache=cache, replay=True)  # the model is never loaded: all answers are cached


def _recorded_paths() -> dict:
    from regen.core.graph import CausePath

    return {k: CausePath.model_validate(v) for k, v in json.loads(RECORDED_PATHS.read_text()).items()}


@pytest.mark.slow
@pytest.mark.parametrize("key", sorted(OBSERVED))
def test_recorded_model_answers_ground_simulate_and_verify(key, tmp_path):
    pytest.importorskip("scenic")
    from regen.pipeline import run_path

    llm = _recorded_llm()
    r = run_path(_recorded_paths()[key], tmp_path / key, llm=llm, pictures=False)
    assert llm.stats.total.model_calls == 0 and llm.stats.total.cache_hits >= 2
    grounder, parts, status = OBSERVED[key]
    scenario = r.scenario()
    assert (scenario.world["grounder"], scenario.world["model_parts"]) == (grounder, parts)
    assert r.verdict.status == status, r.verdict.reason
    assert llm.stats.by_purpose["ground_fsm"].reasks == 0
    if key == "jaywalker":  # the model's own FSM shows the crossing: nothing added
        assert scenario.fsm_source == "model" and r.verdict.fallbacks == []
    else:  # the rules added the cause stages the model left out, and the verdict says so
        assert scenario.fsm_source == "model+rules"
        assert any(f.startswith("cause stages added by rules") for f in r.verdict.fallbacks)
    if key == "ambulance":
        assert [x.split(" (")[0] for x in r.verdict.relaxations] == [
            "stage 3: dropped the model's state ambulance1: same_lane"]


def test_a_state_named_for_a_light_colour_it_does_not_show_is_renamed():
    from regen.core.scenario import FSM, AbstractState, PredicateCall, Stage, StateRef
    from regen.driving.grounding.fsm_rules import honest_names

    def light(name: str, value: str) -> AbstractState:
        return AbstractState(name=name, actor="traffic_light1",
                             all_of=[PredicateCall(name="light_is", args=["traffic_light1"], params={"value": value})])

    states = [light("red", "green"), light("green", "green"), light("turns_red", "red"), light("not_red", "green")]
    fsm_in = FSM(states=states, stages=[Stage(conditions=[StateRef(actor="traffic_light1", state=s.name)])
                                        for s in states])
    out, notes = honest_names(fsm_in)
    assert [s.name for s in out.states] == ["light_is_green", "green", "turns_red", "not_red"]
    (note,) = notes
    assert "'red' renamed 'light_is_green' (the name claims a red light" in note
    assert out.stages[0].conditions[0].state == "light_is_green"
