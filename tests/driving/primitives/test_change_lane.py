import pytest


def test_slower_car_ahead_changes_into_the_ego_lane(ground):
    sc, t, plans = ground("change_lane", "sedan", behavior="change_lane",
                          start_location="ahead_adjacent_lane")
    p, prm = plans["sedan1"], sc.parameters["sedan1"]
    assert prm["v"] <= t.speed_event - 2.0 and t.t_event - 3.0 <= prm["t"] <= t.t_event - 1.0
    assert p.y == pytest.approx(t.frame.lane_d(1 - t.ego_lane))  # starts in the other lane
    assert p.route[-1][1] == pytest.approx(t.frame.lane_d(t.ego_lane))  # ends in the ego's lane
