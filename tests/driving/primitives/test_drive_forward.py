import math

import pytest

from regen.driving.primitives.drive_forward import REACTION_TIME


def test_lead_brakes_before_the_ego_and_stops_ahead_of_it(ground):
    sc, t, plans = ground("stop_abruptly", "sedan", start_location="ahead_same_lane")
    p, brake = plans["sedan1"], sc.parameters["sedan1"]["t"]
    assert p.scenic_behavior == "FollowRoute" and p.dynamic
    assert p.schedule[-1] == (brake, 0.0, 1.0) and t.t_event - 1.5 <= brake <= t.t_event - 0.3
    assert p.x > t.route[0][0]


def test_lead_departs_before_the_waiting_ego(ground):
    sc, t, plans = ground("drive_forward", "suv", start_location="ahead_same_lane")
    p, go = plans["suv1"], sc.parameters["suv1"]["t"]
    assert p.speed0 == 0.0 and p.schedule[0] == (0.0, 0.0, 1.0) and p.schedule[1][0] == go < t.t_event


def test_distracted_follower_brakes_after_its_reaction_time(ground):
    _, t, plans = ground("stop_abruptly", "sedan", start_location="behind_same_lane",
                         driver_state="distracted")
    p = plans["sedan1"]
    assert p.schedule[-1] == (pytest.approx(t.t_event + REACTION_TIME["distracted"]), 0.0, 1.0)
    assert p.x < t.route[0][0]


def test_oncoming_vehicle_drives_towards_the_ego(ground):
    _, t, plans = ground("slow_down", "truck", start_location="oncoming_lane")
    p = plans["truck1"]
    assert p.heading == pytest.approx(t.frame.heading + math.pi)
    assert p.route[-1][0] < p.route[0][0] and p.y > 0  # west-bound, left of the centre line
