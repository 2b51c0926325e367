import math

from regen.driving.world.maps import JUNCTION_RADIUS


def test_red_light_runner_crosses_the_junction_straight(ground):
    sc, t, plans = ground("stop_in_intersection", "sedan", behavior="run_red_light")
    p = plans["sedan1"]
    assert p.heading == math.pi / 2
    assert {x for x, _ in p.route} == {p.x} and p.route[-1][1] > JUNCTION_RADIUS
    v, d0 = sc.parameters["sedan1"]["v"], sc.parameters["sedan1"]["d0"]
    assert t.t_event - 0.6 - 0.1 <= d0 / v <= t.t_event + 1.0 + 0.1  # in the junction around the event
