"""The one home of box geometry and actor categories (regen.driving.world)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from regen.driving.world.actors import actor_category, scenic_class
from regen.driving.world.geometry import DOOR_WIDTH, corners, door_footprint, gap, overlap, to_local


def test_corners_of_a_turned_box():
    # a 4 x 2 m box facing +y: its front left corner is 2 m ahead (+y) and 1 m left (-x)
    c = corners(10.0, 5.0, math.pi / 2, 4.0, 2.0)
    assert c.shape == (4, 2)
    assert c[0] == pytest.approx([9.0, 7.0])
    assert c[2] == pytest.approx([11.0, 3.0])  # rear right


def test_scalars_and_steps_agree():
    # the gym checks one step with scalars, the trace check all steps with arrays: same answers
    xb = np.array([3.0, 4.5, 10.0])
    hit = overlap(np.zeros(3), np.zeros(3), np.zeros(3), 4.0, 2.0, xb, np.zeros(3), np.zeros(3), 4.0, 2.0)
    assert hit.tolist() == [True, False, False]
    assert [bool(overlap(0.0, 0.0, 0.0, 4.0, 2.0, x, 0.0, 0.0, 4.0, 2.0)) for x in xb] == hit.tolist()
    ca = corners(np.zeros(3), np.zeros(3), np.zeros(3), 4.0, 2.0)
    cb = corners(xb, np.zeros(3), np.zeros(3), 4.0, 2.0)
    g = gap(ca, cb, hit)
    assert g == pytest.approx([0.0, 0.5, 6.0])  # bumper to bumper, 0 where they overlap
    assert float(gap(corners(0.0, 0.0, 0.0, 4.0, 2.0), corners(10.0, 0.0, 0.0, 4.0, 2.0))) == pytest.approx(6.0)


def test_touching_boxes_overlap():
    assert bool(overlap(0.0, 0.0, 0.0, 4.0, 2.0, 4.0, 0.0, 0.0, 4.0, 2.0))


def test_an_open_door_grows_the_left_side_only():
    x, y, w = door_footprint(np.array([0.0, 0.0]), np.zeros(2), np.zeros(2), 2.0, np.array([False, True]))
    assert w.tolist() == [2.0, 2.0 + DOOR_WIDTH]
    assert y.tolist() == [0.0, DOOR_WIDTH / 2]  # facing +x, left is +y; the right side stays at -1 m
    assert (y - w / 2).tolist() == [-1.0, -1.0]


def test_to_local_is_ahead_and_left():
    assert to_local(1.0, 1.0, math.pi / 2, 1.0, 3.0) == pytest.approx((2.0, 0.0))
    assert to_local(1.0, 1.0, math.pi / 2, 0.0, 1.0) == pytest.approx((0.0, 1.0))


@pytest.mark.parametrize(("asset", "kind", "category", "cls"), [
    ("sedan", "agent", "vehicle", "Car"),
    ("adult", "agent", "pedestrian", "Pedestrian"),
    ("traffic_cone", "object", "static", "Object"),
    ("parked_car", "object", "static", "Car"),  # static, but a Scenic Car half on the curb
    ("traffic_light", "object", "light", "Object"),
    ("gnss", "sensor", "sensor", ""),
    ("ego", "ego", "vehicle", "Car"),
])
def test_one_category_for_every_use(asset, kind, category, cls):
    assert actor_category(asset, kind) == category
    assert scenic_class(asset, kind) == cls
