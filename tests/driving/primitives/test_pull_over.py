import pytest

from regen.driving.primitives.pull_over import curb_d, pull_length
from regen.driving.world.egos import EGO_SIZE


@pytest.mark.parametrize("template", ["slow_down", "stop_abruptly"])
def test_car_ahead_pulls_over_to_the_curb_shortly_before_the_ego_reacts(ground, template):
    sc, t, plans = ground(template, "sedan", behavior="pull_over", start_location="ahead_same_lane")
    p, prm = plans["sedan1"], sc.parameters["sedan1"]
    assert p.y == pytest.approx(t.frame.lane_d(t.ego_lane))  # starts in the ego's lane
    assert prm["v"] <= t.speed_event and t.t_event - 3.0 <= prm["t"] <= t.t_event - 0.8
    ego_then = t.s_event - t.speed_event * (t.t_event - prm["t"])
    gap = prm["s"] + prm["v"] * prm["t"] - ego_then - (p.length + EGO_SIZE[0]) / 2  # bumper to bumper
    assert 6.0 - 0.1 <= gap <= 30.0 + 0.1  # ahead of the ego when it pulls over
    d = curb_d(t, p.width)
    assert abs(d) > abs(t.frame.lane_d(t.ego_lane)) + t.frame.lane_width / 2  # out of the ego's lane
    assert p.lane_change is not None and p.lane_change.d_to == d and p.lane_change.length == pull_length(prm["v"])
    assert p.route[-1][1] == pytest.approx(d)
    (_, v0, _), (brake, v1, level) = p.schedule
    assert v0 == prm["v"] and v1 == 0.0 and 0 < level < 1 and brake > prm["t"]


def test_its_cause_is_the_pulling_over_and_it_ends_stopped_out_of_the_lane(ground):
    sc, _, _ = ground("slow_down", "sedan", behavior="pull_over", start_location="ahead_same_lane")
    states = {s.name: s for s in sc.fsm.states if s.actor == "sedan1"}
    assert states["pulling_over"].cause
    assert [c.name for c in states["pulling_over"].all_of] == ["changing_lane", "ahead_of"]
    curb = {(c.name, c.negate) for c in states["at_the_curb"].all_of}
    assert curb == {("stopped", False), ("same_lane", True)}
