"""The desired ego action of each driving ego template, derived from its FSM states and checked
against hand-built traces."""

from __future__ import annotations

import pytest
from dataset_builders import brake, drive_off, lane_change, scenario, steady, trace, turn, verdict

from regen.dataset.labels import LeftOut, label
from regen.driving.world.states import pred

CAR = {"car1": ("sedan", "agent", steady(8.0, x0=15.0))}


@pytest.mark.parametrize(("template", "ego", "action"), [
    ("stop_abruptly", brake(10.0, 0.0), "stop"),
    ("stop_in_intersection", brake(10.0, 0.0), "stop"),
    ("stop_after_turn", brake(6.0, 0.0), "stop"),
    ("slow_down", brake(12.0, 4.0, decel=3.0), "slow_down"),
    ("drive_forward", drive_off(), "accelerate"),
    ("change_lane", lane_change(+1.0), "change_lane_left"),
])
def test_each_ego_template_gets_its_label(template: str, ego, action: str) -> None:
    sc = scenario(template)
    got = label(sc, trace(ego, CAR), verdict(sc))
    assert got.action == action
    assert got.t == pytest.approx(5.0)  # the stage of the ego's first reaction state


@pytest.mark.parametrize(("side", "action"), [(+1.0, "turn_left"), (-1.0, "turn_right")])
def test_a_turning_ego_without_template_turns_the_way_the_trace_does(side: float, action: str) -> None:
    sc = scenario(None, [("driving", [pred("moving", "ego", min_speed=3.0)]), ("turning", [pred("turning", "ego")])])
    assert label(sc, trace(turn(side), CAR), verdict(sc)).action == action


@pytest.mark.parametrize(("template", "ego", "why"), [
    ("stop_abruptly", steady(10.0), "never stops"),
    ("slow_down", brake(12.0, 0.0), "stops at"),
    ("drive_forward", steady(0.0), "reaches only"),
    ("change_lane", lane_change(-1.0), "to the right"),
])
def test_a_trace_that_contradicts_the_template_is_left_out(template: str, ego, why: str) -> None:
    sc = scenario(template)
    with pytest.raises(LeftOut) as err:
        label(sc, trace(ego, CAR), verdict(sc))
    assert err.value.reason == "trace contradicts the label"
    assert why in err.value.detail


def test_an_unreached_reaction_stage_gives_no_decision_moment() -> None:
    sc = scenario("stop_abruptly")
    vd = verdict(sc)
    vd.stages[1].reached_at = None
    with pytest.raises(LeftOut, match="no decision moment"):
        label(sc, trace(brake(10.0, 0.0), CAR), vd)
