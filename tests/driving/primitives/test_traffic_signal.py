import math

import pytest


def test_light_turns_red_after_yellow_before_the_ego_stops(ground):
    sc, t, plans = ground("stop_in_intersection", "traffic_light", light_state="turns_red")
    p, red = plans["traffic_light1"], sc.parameters["traffic_light1"]["t"]
    assert sc.entity("traffic_light1").behavior is None and set(sc.parameters["traffic_light1"]) == {"t"}
    assert 2.0 <= red and t.t_event - 2.5 <= red <= t.t_event - 0.2
    assert [v for _, v in p.states["light_state"]] == ["green", "yellow", "red"]
    assert p.heading == 0.0 and not p.dynamic  # at the junction corner


def test_on_a_straight_road_it_stands_at_a_crossing_facing_the_ego(ground):
    _, t, plans = ground("stop_abruptly", "traffic_light", light_state="red", start_location="roadside_ahead")
    p = plans["traffic_light1"]
    assert p.comment == "traffic light at a crossing" and p.cls == "Object"
    assert p.heading == pytest.approx(t.frame.heading + math.pi) and p.x > t.s_end
