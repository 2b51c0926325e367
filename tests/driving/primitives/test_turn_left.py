import math

from regen.driving.world.egos import JUNCTION_CX
from regen.driving.world.maps import JUNCTION_RADIUS


def test_oncoming_car_turns_left_into_the_south_arm(ground):
    sc, t, plans = ground("stop_in_intersection", "suv", behavior="turn_left", target_speed="slow")
    p = plans["suv1"]
    assert t.map == "four_way" and p.heading == math.pi
    assert p.x > JUNCTION_CX + JUNCTION_RADIUS and p.y > 0
    assert p.route[-1][1] < -JUNCTION_RADIUS and p.route[-1][0] < JUNCTION_CX
    assert "d0" in sc.parameters["suv1"]
