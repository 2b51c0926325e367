"""The rule that rejects a cause happening somewhere else, after the judge accepted it."""

from __future__ import annotations

import pytest
from fake_expansion_model import ScriptedModel

from regen.core.behavior import Behavior
from regen.expand import Limits, expand
from regen.expand.edges import judge_candidates, ruled_out
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
