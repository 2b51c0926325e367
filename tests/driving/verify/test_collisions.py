"""Collisions and infractions of constructed traces (no simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from regen.core.trace import ActorTrack, Trace
from regen.driving.verify.collisions import analyze, checked_pairs, overlap
from regen.verify.predicates import get_predicate

DT = 0.1  # [s]
N = 50  # steps


def _track(xs, ys, heading=0.0, *, asset="sedan", kind="agent", length=4.6, width=1.9, states=None):
    xs = list(np.broadcast_to(np.asarray(xs, float), (N,)))
    ys = list(np.broadcast_to(np.asarray(ys, float), (N,)))
    hs = list(np.broadcast_to(np.asarray(heading, float), (N,)))
    return ActorTrack(asset=asset, kind=kind, length=length, width=width, x=xs, y=ys, heading=hs,
                      speed=[0.0] * N, states=states or {})


def _trace(**actors) -> Trace:
    return Trace(dt=DT, times=[round(k * DT, 6) for k in range(N)], actors=actors)


def _ego_driving(v=10.0, x0=0.0, y=0.0):
    return _track(x0 + v * DT * np.arange(N), y, asset="ego", kind="ego")


def test_constructed_crash_is_detected():
    # the ego drives at 10 m/s into a car stopped 20 m ahead (bumper gap 15.4 m): contact after 1.54 s
    tr = _trace(ego=_ego_driving(), car=_track(20.0, 0.0))
    rep = analyze(tr)
    first = rep.first_collision
    assert first is not None and first.actors == ("ego", "car")
    assert first.t == pytest.approx(1.6, abs=1e-9)  # first step at which the boxes overlap
    assert "collision of ego and car" in first.describe()
    (pair,) = rep.pairs
    assert pair.min_distance == 0.0 and pair.min_ttc == 0.0
    assert rep.colliding[:, 0].sum() > 0


def test_near_miss_is_not_a_collision():
    # the ego passes a stopped car in the next lane with 0.3 m between their sides
    lateral = 1.9 + 0.3
    tr = _trace(ego=_ego_driving(x0=-20.0), car=_track(5.0, lateral))
    rep = analyze(tr)
    assert rep.collisions == []
    assert rep.min_distance("ego") == pytest.approx(0.3, abs=1e-6)
    assert math.isinf(rep.min_ttc("ego")) or rep.min_ttc("ego") > 0


def test_heading_matters():
    # a long car (10 m) 4 m to the ego's side: along the x axis it reaches the ego, turned 90
    # degrees it does not; the reverse holds for a car 6 m ahead
    ego = _track(0.0, 0.0, asset="ego", kind="ego")
    beside = dict(length=10.0, width=2.0)
    along = _track(np.linspace(0, 1, N), 3.0, 0.0, **beside)
    across = _track(np.linspace(0, 1, N), 3.0, math.pi / 2, **beside)
    assert not analyze(_trace(ego=ego, truck=along)).collisions  # side gap 3 - 0.95 - 1 = 1.05 m
    assert analyze(_trace(ego=ego, truck=across)).collisions  # reaches 5 m to the side


def test_overlap_is_symmetric_and_rotation_aware():
    ones = np.ones(1)
    # two 4x2 boxes whose centres are 3.5 m apart along x: overlap when aligned along x only
    assert overlap(0 * ones, 0 * ones, 0 * ones, 4, 2, 3.5 * ones, 0 * ones, 0 * ones, 4, 2)[0]
    assert not overlap(0 * ones, 0 * ones, 0 * ones, 4, 2, 3.5 * ones, 0 * ones, math.pi / 2 * ones, 4, 2)[0]
    assert not overlap(3.5 * ones, 0 * ones, math.pi / 2 * ones, 4, 2, 0 * ones, 0 * ones, 0 * ones, 4, 2)[0]


def test_pairs_need_a_vehicle_and_motion():
    tr = _trace(ego=_ego_driving(), walker=_track(30.0, 5.0, asset="adult", length=0.5, width=0.5),
                walker2=_track(31.0, 5.0, asset="adult", length=0.5, width=0.5),
                cone=_track(60.0, 0.0, asset="cone", kind="object", length=0.4, width=0.4),
                gps=_track(0.0, 0.0, asset="gnss", kind="sensor"))
    assert set(checked_pairs(tr)) == {("ego", "walker"), ("ego", "walker2"), ("ego", "cone")}


def test_static_object_and_pedestrian_collisions():
    tr = _trace(ego=_ego_driving(), adult=_track(30.0, 0.0, asset="adult", length=0.5, width=0.5),
                cone=_track(45.0, 0.5, asset="cone", kind="object", length=0.4, width=0.4))
    kinds = [e.actors for e in analyze(tr).collisions]
    assert kinds == [("ego", "adult"), ("ego", "cone")]


def test_red_light_and_off_road():
    red = ["green"] * 10 + ["red"] * (N - 10)
    light = _track(30.0, -5.0, math.pi, asset="traffic_light", kind="object", length=0.6, width=0.6,
                   states={"light_state": red})
    ego = _ego_driving()
    ego.states["on_road"] = [True] * 40 + [False] * (N - 40)
    rep = analyze(_trace(ego=ego, light=light))
    kinds = [(e.kind, e.actors) for e in rep.events]
    assert ("red_light", ("ego", "light")) in kinds
    assert ("off_road", ("ego",)) in kinds
    assert rep.collisions == []  # a light at the roadside is not an obstacle


def test_an_open_door_widens_the_footprint():
    # a parked car 2.5 m to the ego's right (side gap 0.6 m): its door opens towards the ego
    door = ["closed"] * 20 + ["open"] * (N - 20)
    parked = _track(30.0, -2.5, asset="parked_car", kind="object", states={"door": door})
    rep = analyze(_trace(ego=_ego_driving(), parked=parked))
    (hit,) = rep.collisions
    assert hit.actors == ("ego", "parked") and hit.step >= 20
    shut = _track(30.0, -2.5, asset="parked_car", kind="object", states={"door": ["closed"] * N})
    assert analyze(_trace(ego=_ego_driving(), parked=shut)).collisions == []
    assert get_predicate("collision", "driving").fn(_trace(ego=_ego_driving(), parked=parked), ["ego"], {}).any()


def test_green_light_is_no_infraction():
    light = _track(30.0, -5.0, math.pi, asset="traffic_light", kind="object", length=0.6, width=0.6,
                   states={"light_state": ["green"] * N})
    assert analyze(_trace(ego=_ego_driving(), light=light)).events == []


def test_predicates_are_registered():
    tr = _trace(ego=_ego_driving(), car=_track(20.0, 0.0))
    collides = get_predicate("collides", "driving")
    collision = get_predicate("collision", "driving")
    hit = collides.fn(tr, ["ego", "car"], {})
    assert hit.dtype == bool and hit.shape == (N,) and hit[16] and not hit[15] and not hit[0]
    assert (collision.fn(tr, ["ego"], {}) == hit).all()
