"""The rule that rejects a cause happening somewhere else, after the judge accepted it."""

from __future__ import annotations

import pytest
from fake_expansion_model import ScriptedModel

from regen.core.behavior import Behavior
from regen.expand import Limits, expand
from regen.expand.construct import judge_candidates
from regen.expand.edges import ruled_out
from regen.expand.rules import happens_elsewhere
from regen.llm import LLM
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
DOOR = "the robot opens the door"

ELSEWHERE = [
    ("a jaywalker in another city", "in another city"),
    ("a pedestrian on the other side of town presses a crossing button", "on the other side of town"),
    ("a cyclist rides in a bike lane on a road across the river", "across the river"),
    ("a car on another road speeds up", "on another road"),
    ("it is raining in another country", "in another country"),
    ("a truck far away honks", "far away"),
    ("the neighbour's dog barks three blocks away", "blocks away"),
]
HERE = ["a car from another road turns into the ego's lane", "a child runs across the road",
        "the car far ahead brakes hard", "a pedestrian crosses at the far end of the crosswalk",
        "a car in the next lane brakes", "the bus on the other side of the road stops",
        "the pet is waiting outside to come in", "a guest in the other room wants water"]


@pytest.mark.parametrize(("cause", "words"), ELSEWHERE)
def test_causes_placed_elsewhere_are_found(cause: str, words: str) -> None:
    assert happens_elsewhere(cause) == words


@pytest.mark.parametrize("cause", HERE)
def test_causes_here_are_left_to_the_judge(cause: str) -> None:
    assert happens_elsewhere(cause) is None
    assert ruled_out("driving", cause) is None


@pytest.mark.parametrize("domain", ["driving", "manipulation"])
def test_expansion_rejects_an_accepted_cause_that_happens_elsewhere(domain: str) -> None:
    text = {"driving": STOP, "manipulation": DOOR}[domain]
    far, near = {"driving": ("a jaywalker in another city", "a child runs across the road"),
                 "manipulation": ("a pet waits at a door in another town", "the pet is waiting outside")}[domain]
    model = ScriptedModel(causes={text: [far, near]},  # the judge finds both plausible
                          entities={near: ["child" if domain == "driving" else "pet"]})
    behavior = Behavior(text=text, domain=domain, params={"reward": "open_door"} if domain == "manipulation" else {})
    g = expand(behavior, LLM(FunctionProvider(model)), limits=Limits(max_depth=1, max_causes=4, max_entities=2))
    nodes = {n.label: n for n in g.nodes.values() if n.kind == "event"}
    judge, rule = nodes[far].history[-2:]
    assert (judge.action, judge.by) == ("accepted", "model")
    assert (rule.action, rule.by, rule.call_id) == ("rejected", "rule", None)
    assert "happens somewhere else ('in another" in rule.reason
    assert nodes[far].status == "rejected" and nodes[near].status != "rejected"


def test_the_edge_evaluation_applies_the_same_rules() -> None:
    far, near, cabin = "a jaywalker in another city", "a child runs across the road", "the ego's passenger opens a window"
    model = ScriptedModel(causes={STOP: []})  # its judge says yes to every candidate
    got = judge_candidates(LLM(FunctionProvider(model)), "event->event", STOP, [far, near, cabin], domain="driving")
    assert got == {near}


OPPOSITES = [  # (effect, cause, the cause's words quoted): the cause makes the ego do the opposite
    ("the ego-vehicle drove off from a stop", "a pedestrian steps into the path of the ego-vehicle", "steps into"),
    ("the ego-vehicle accelerates", "the car ahead brakes hard", "brakes hard"),
    ("the ego-vehicle pulls away from the kerb", "the light turns red", "turns red"),
    ("the ego-vehicle stopped abruptly", "the traffic light turned green", "turned green"),
    ("the ego-vehicle waited at the junction", "the junction was clear", "junction was clear"),
    ("the car stopped abruptly", "the traffic light turned green", "turned green"),  # 'the car' alone is the ego
]
NOT_OPPOSITES = [
    ("the ego-vehicle drove off from a stop", "the traffic light turned green"),  # a drive-off, not a stop
    ("the ego-vehicle drove off from a stop", "the car ahead started moving"),
    ("the ego-vehicle stopped abruptly", "a child ran into the road after a ball"),
    ("the ego-vehicle stopped abruptly", "a car ran the red light at the junction"),
    ("the ego-vehicle changed lanes to the right", "a bus stopped at a bus stop in the ego's lane"),
    ("a child ran into the road", "the traffic light turned green"),  # not the ego's effect
    ("the car ahead stopped abruptly", "the traffic light turned green"),  # another car, not the ego
]


@pytest.mark.parametrize(("effect", "cause", "words"), OPPOSITES)
def test_a_cause_that_makes_the_ego_do_the_opposite_is_ruled_out(effect: str, cause: str, words: str) -> None:
    why = ruled_out("driving", cause, effect)
    assert why is not None and why.startswith(f"makes the opposite happen ('{words}'")
    assert ruled_out("driving", cause) is None  # without its effect, no opposite


@pytest.mark.parametrize(("effect", "cause"), NOT_OPPOSITES)
def test_causes_of_the_same_direction_are_left_to_the_judge(effect: str, cause: str) -> None:
    assert ruled_out("driving", cause, effect) is None


def test_manipulation_has_no_opposites_and_the_eval_judges_with_the_effect() -> None:
    assert ruled_out("manipulation", "the light turned green", "the robot stopped the faucet") is None
    drive_off = "the ego-vehicle drove off from a stop"
    model = ScriptedModel(causes={drive_off: []})  # its judge says yes to every candidate
    got = judge_candidates(LLM(FunctionProvider(model)), "event->event", drive_off,
                           ["the traffic light turned green", "a pedestrian steps into the path"], domain="driving")
    assert got == {"the traffic light turned green"}
