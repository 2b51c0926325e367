import math

import pytest


def test_pedestrian_walks_towards_the_ego_on_the_sidewalk(ground):
    _, t, plans = ground("slow_down", "adult", behavior="walk_along")
    p = plans["adult1"]
    assert p.heading == pytest.approx(t.frame.heading + math.pi)
    assert {round(y, 6) for _, y in p.route} == {round(t.frame.sidewalk_d("right"), 6)}
    assert p.route[-1][0] < p.route[0][0]
