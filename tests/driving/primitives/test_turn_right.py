import math

from regen.driving.world.egos import JUNCTION_CX
from regen.driving.world.maps import JUNCTION_RADIUS


def test_cross_street_car_turns_right_into_the_ego_direction(ground):
    _, t, plans = ground("stop_in_intersection", "sedan", behavior="turn_right")
    p = plans["sedan1"]
    assert p.heading == math.pi / 2 and p.y < -JUNCTION_RADIUS
    assert p.route[-1][0] > JUNCTION_CX + JUNCTION_RADIUS and p.route[-1][1] < 0  # east-bound lane
