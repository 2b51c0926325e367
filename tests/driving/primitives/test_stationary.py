import math

import pytest


def test_debris_stands_in_the_ego_lane_beyond_where_the_ego_stops(ground):
    sc, t, plans = ground("stop_abruptly", "debris", start_location="ahead_same_lane")
    p = plans["debris1"]
    assert not p.dynamic and p.scenic_behavior == "" and p.cls == "Object"
    assert p.y == pytest.approx(t.frame.lane_d(0)) and p.x > t.s_end + 2.3
    assert "v" in sc.parameters["debris1"] and sc.entity("debris1").behavior == "stationary"


def test_parked_car_opens_its_door_shortly_before_the_ego_brakes(ground):
    sc, t, plans = ground("stop_abruptly", "parked_car", door="opens")
    p = plans["parked_car1"]
    opens = sc.parameters["parked_car1"]["t"]
    assert t.t_event - 2.5 <= opens <= t.t_event - 0.3
    assert p.states["door"] == [(0.0, "closed"), (opens, "open")]
    assert p.cls == "Car" and abs(p.y) > t.frame.lane_width  # at the curb, not in the ego's lane


def test_at_a_junction_it_stands_at_the_corner(ground):
    _, t, plans = ground("stop_in_intersection", "traffic_cone", start_location="junction_corner")
    p = plans["traffic_cone1"]
    assert p.heading == 0.0 and p.x < t.frame.ox and p.y < 0 and not p.dynamic
    assert math.isfinite(p.x)
