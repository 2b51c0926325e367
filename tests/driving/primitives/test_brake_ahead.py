import pytest

from regen.core.behavior import Behavior
from regen.core.graph import CausePath, PathEntity
from regen.driving.primitives.shared.lead import FULL_BRAKE, SLOW_LEVEL, slow_speed
from regen.driving.world.egos import EGO_SIZE


def test_the_lead_brakes_hard_shortly_before_the_ego_stops_and_stops_ahead_of_it(ground):
    sc, t, plans = ground("stop_abruptly", "truck", behavior="brake_ahead")
    p, prm = plans["truck1"], sc.parameters["truck1"]
    assert p.y == pytest.approx(t.frame.lane_d(t.ego_lane))  # in the ego's lane
    assert p.schedule == [(0.0, prm["v"], 0.0), (prm["t"], 0.0, 1.0)]  # then a full stop
    assert t.t_event - 1.5 <= prm["t"] <= t.t_event - 0.3 and prm["v"] >= t.speed_event
    stop = prm["s"] + prm["v"] * prm["t"] + prm["v"] ** 2 / (2 * FULL_BRAKE)  # where it rests
    assert t.s_end + (p.length + EGO_SIZE[0]) / 2 + 1.0 <= stop <= t.s_end + (p.length + EGO_SIZE[0]) / 2 + 11.0


def test_around_an_ego_that_slows_down_it_brakes_to_the_speed_the_ego_slows_to(ground):
    sc, t, plans = ground("slow_down", "sedan", behavior="brake_ahead")
    p, prm = plans["sedan1"], sc.parameters["sedan1"]
    assert abs(prm["v"] - t.speed_event) <= 1.0 + 1e-9
    assert p.schedule[-1] == (prm["t"], slow_speed(t), SLOW_LEVEL) and slow_speed(t) < t.speed_event
    ego_then = t.s_event - t.speed_event * (t.t_event - prm["t"])
    gap = prm["s"] + prm["v"] * prm["t"] - ego_then - (p.length + EGO_SIZE[0]) / 2
    assert 8.0 - 0.1 <= gap <= 25.0 + 0.1


def test_its_cause_is_the_braking_and_it_ends_stopped_or_slow_ahead_of_the_ego(ground):
    for template, final in (("stop_abruptly", "stopped_ahead"), ("slow_down", "slow_ahead")):
        sc, _, _ = ground(template, "sedan", behavior="brake_ahead")
        states = {s.name: s for s in sc.fsm.states if s.actor == "sedan1"}
        assert states["braking"].cause and [c.name for c in states["braking"].all_of] == ["braking", "in_front"]
        assert final in states


def test_broken_brake_lights_the_graph_names_are_kept():
    sc, _, _ = _ground("stop_abruptly", behavior="brake_ahead", brake_lights="broken")
    assert sc.entity("sedan1").properties["brake_lights"] == "broken"


def test_nobody_brakes_ahead_of_an_ego_waiting_at_its_start():
    sc, _, _ = _ground("drive_forward", behavior="brake_ahead")
    assert sc.solver.status == "infeasible"
    assert any("waits at its start" in c for c in sc.solver.conflicts)


def _ground(template: str, **properties: str):
    from regen.driving.grounding.rules import ground_rule_based

    cause = "a sedan does something"
    path = CausePath(behavior=Behavior(text=f"the ego-vehicle does {template}", domain="driving",
                                       params={"ego_template": template}),
                     events=[cause, f"the ego-vehicle does {template}"],
                     entities=[PathEntity(asset="sedan", event=cause,
                                          properties={k: [v] for k, v in properties.items()})])
    return ground_rule_based(path), None, None
