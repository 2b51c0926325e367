"""The but-for check's decisions on a world whose reference runs are given (no simulator), the
cause's entities as the words name them, and the narrative's claims against the trace."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from regen.core.verdict import ReferenceRun
from regen.verify.causal import but_for, explains
from regen.verify.claims import check_narrative


@dataclass
class World:
    """Shows the behavior in a world exactly when one of ``makers`` is present; ``late``: the
    cause entities' reaction is not to them (shown False, happened True)."""

    makers: set[str]
    late: bool = False
    by: str = "reference driver"
    behavior: str = "stops"
    asked: list[frozenset[str]] = field(default_factory=list)

    def run(self, removed: frozenset[str]) -> ReferenceRun:
        self.asked.append(removed)
        present = self.makers - removed
        shown = bool(present)
        return ReferenceRun(shown=shown and not (self.late and not removed), happened=shown,
                            summary=f"stops for {sorted(present)}" if shown else "never stops")


def test_a_cause_that_alone_makes_the_behavior_is_caused():
    c = but_for(World({"child1"}), ["child1"], ["cone1"])
    assert c.status == "caused" and c.confounders == []
    assert c.with_cause.shown and not c.without_cause.shown
    (o,) = c.others
    assert o.entity == "cone1" and o.alone_shows is False and o.without_it_shows is True


def test_another_entity_that_explains_it_alone_is_a_confounder():
    c = but_for(World({"child1", "traffic_light1"}), ["child1"], ["traffic_light1", "cone1"])
    assert c.status == "confounded" and c.confounders == ["traffic_light1"]
    assert "traffic_light1 alone makes the reference driver stop" in c.reason


def test_a_reaction_to_something_else_still_finds_the_confounder():
    c = but_for(World({"traffic_light1"}, late=True), ["child1"], ["traffic_light1"])
    assert c.status == "confounded" and c.confounders == ["traffic_light1"]


def test_a_cause_the_reference_ignores_is_not_sufficient():
    w = World(set())
    c = but_for(w, ["child1"], ["cone1"])
    assert c.status == "not_sufficient" and "does not stop" in c.reason
    assert w.asked == [frozenset()]  # nothing more to check


def test_a_behavior_with_no_single_explanation_is_not_necessary():
    c = but_for(World({"road"}), ["child1"], [])
    assert c.status == "not_necessary" and "the road alone" in c.reason


@pytest.mark.parametrize(("status", "feasible", "explained"), [
    ("caused", True, True), ("confounded", True, False), ("not_sufficient", True, False),
    ("not_checked", True, True), ("caused", False, False)])
def test_explains(status, feasible, explained):
    from regen.core.verdict import Causal

    assert explains(Causal(status=status, reason=""), feasible) is explained


def test_a_claimed_collision_the_trace_does_not_show_is_marked():
    text = ("A cyclist crosses the road. The ego-vehicle stops abruptly due to the cyclist, causing a "
            "collision. It brakes to avoid a collision.")
    (note,) = check_narrative(text, collisions=[], robot_stood=True, robot="ego-vehicle")
    assert note.startswith("the model's claim: 'The ego-vehicle stops abruptly due to the cyclist, causing a collision.'")
    assert "no collision" in note
    assert check_narrative(text, collisions=["the ego hit bicycle1 at t=6.0 s"], robot_stood=True) == []
    assert check_narrative(text, collisions=None, robot_stood=None) == []  # nothing known: no check


def test_a_claimed_stop_of_a_robot_that_never_stood_is_marked():
    text = "The ego-vehicle comes to a stop behind the truck."
    (note,) = check_narrative(text, collisions=[], robot_stood=False, robot="ego-vehicle")
    assert "never stands still" in note
    assert check_narrative(text, collisions=[], robot_stood=True, robot="ego-vehicle") == []
