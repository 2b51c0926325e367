import pytest


def test_faster_car_from_behind_cuts_in_ahead_of_the_ego(ground):
    sc, t, plans = ground("slow_down", "sedan", behavior="cut_in", target_speed="fast")
    p, prm = plans["sedan1"], sc.parameters["sedan1"]
    assert p.x < t.route[0][0] and prm["v"] >= t.speed_event + 2.0
    cut = prm["s"] + prm["v"] * prm["t"]  # where it starts to change lanes [m]
    ego_then = t.s_event - t.speed_event * (t.t_event - prm["t"])
    assert cut > ego_then
    assert p.route[-1][1] == pytest.approx(t.frame.lane_d(t.ego_lane))
