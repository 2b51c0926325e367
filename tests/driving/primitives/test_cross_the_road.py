import pytest


def test_child_crosses_from_the_far_side_to_the_near_side(ground):
    sc, t, plans = ground("stop_abruptly", "child", behavior="cross_the_road",
                          start_location="roadside_opposite_ahead")
    p = plans["child1"]
    assert p.scenic_behavior == "WalkRoute" and p.cls == "Pedestrian"
    assert p.route[0][1] == pytest.approx(t.frame.sidewalk_d("left"))
    assert p.route[-1][1] == pytest.approx(t.frame.sidewalk_d("right"))
    assert p.schedule[1][0] == sc.parameters["child1"]["t"]
