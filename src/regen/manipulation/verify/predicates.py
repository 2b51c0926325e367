"""Manipulation predicates over recorded PyBullet traces (numpy only; registered lazily).

Geometry uses each actor's axis-aligned box: centre ``x, y, z`` and extents ``length`` (x),
``width`` (y), ``height`` (z) from the trace. Directions are seen from the robot, which faces
+x: ``left_of`` is +y, ``in_front_of`` means between the reference and the robot (smaller x),
``behind``/``outside`` mean beyond the reference (larger x; for a wall with a door or window,
the other side of the wall).
"""

from __future__ import annotations

import numpy as np

from regen.core.trace import Trace
from regen.verify.predicates import arr, predicate, state

DOM = ("manipulation",)
TOL = 0.03  # [m] contact / boundary tolerance


def _box(trace: Trace, name: str) -> tuple[np.ndarray, ...]:
    a = trace.actors[name]
    x, y, z = arr(trace, name, "x"), arr(trace, name, "y"), arr(trace, name, "z")
    hl, hw, hh = a.length / 2, a.width / 2, a.height / 2
    return x - hl, x + hl, y - hw, y + hw, z - hh, z + hh


def _has(trace: Trace, name: str, key: str) -> bool:
    return key in trace.actors[name].states


def _num(trace: Trace, name: str, key: str) -> np.ndarray:
    return np.asarray([np.nan if v is None else float(v) for v in state(trace, name, key)])


@predicate("joint_open", 1, "the furniture's joint is open at least `at_least` (0 closed .. 1 open)",
           domains=DOM, params={"at_least": 0.5})
def _joint_open(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    if not _has(trace, args[0], "joint_fraction"):
        return np.zeros(trace.steps, dtype=bool)
    return _num(trace, args[0], "joint_fraction") >= float(params.get("at_least", 0.5))


@predicate("joint_closed", 1, "the furniture's joint is open at most `at_most` (0 closed .. 1 open)",
           domains=DOM, params={"at_most": 0.1})
def _joint_closed(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    if not _has(trace, args[0], "joint_fraction"):
        return np.zeros(trace.steps, dtype=bool)
    return _num(trace, args[0], "joint_fraction") <= float(params.get("at_most", 0.1))


@predicate("holding", 2, "the robot (first) holds the second actor in its gripper", domains=DOM)
def _holding(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return np.array([v == args[1] for v in state(trace, args[0], "holding")], dtype=bool)


@predicate("ee_near", 2, "the robot's end effector is within `distance` [m] of the second actor's "
           "handle (or centre)", domains=DOM, params={"distance": 0.05})
def _ee_near(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    robot, other = args
    ee = np.stack([_num(trace, robot, k) for k in ("ee_x", "ee_y", "ee_z")])
    if _has(trace, other, "handle_x"):
        tgt = np.stack([_num(trace, other, k) for k in ("handle_x", "handle_y", "handle_z")])
    else:
        tgt = np.stack([arr(trace, other, k) for k in ("x", "y", "z")])
    return np.linalg.norm(ee - tgt, axis=0) <= float(params.get("distance", 0.05))


def _height(trace: Trace, b: str, key: str, face: int) -> np.ndarray:
    """Per step, the height [m] ``key`` recorded for ``b`` (its top surface, the free height
    under it), else that face of its box (``face``: 4 bottom, 5 top, as :func:`_box` orders them)."""
    return _num(trace, b, key) if _has(trace, b, key) else _box(trace, b)[face]


def _centre_over(trace: Trace, a: str, b: str) -> np.ndarray:
    """Per step: is the centre of ``a`` within the footprint (x, y) of ``b``?"""
    x, y = arr(trace, a, "x"), arr(trace, a, "y")
    x0, x1, y0, y1, _, _ = _box(trace, b)
    return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)


@predicate("on", 2, "the first actor rests on top of the second (its bottom at the other's top, "
           "its centre over the other's footprint)", domains=DOM)
def _on(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    a, b = args
    return (np.abs(_box(trace, a)[4] - _height(trace, b, "top", 5)) <= TOL) & _centre_over(trace, a, b)


@predicate("inside", 2, "the first actor's centre is inside the second's interior (cavity) or box",
           domains=DOM)
def _inside(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    a, b = args
    p = [arr(trace, a, k) for k in ("x", "y", "z")]
    if _has(trace, b, "cavity_lo_x"):
        lo = [_num(trace, b, f"cavity_lo_{k}") for k in "xyz"]
        hi = [_num(trace, b, f"cavity_hi_{k}") for k in "xyz"]
    else:
        x0, x1, y0, y1, z0, z1 = _box(trace, b)
        lo, hi = [x0, y0, z0], [x1, y1, z1]
    out = np.ones(trace.steps, dtype=bool)
    for v, low, high in zip(p, lo, hi, strict=True):
        out &= (v >= low - TOL) & (v <= high + TOL)
    return out


@predicate("under", 2, "the first actor stands under the second (inside its footprint, below "
           "its free height)", domains=DOM)
def _under(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    a, b = args
    return _centre_over(trace, a, b) & (_box(trace, a)[5] <= _height(trace, b, "under", 4) + TOL)


def _gap(trace: Trace, a: str, b: str) -> np.ndarray:
    ax0, ax1, ay0, ay1, _, _ = _box(trace, a)
    bx0, bx1, by0, by1, _, _ = _box(trace, b)
    dx = np.maximum(0.0, np.maximum(bx0 - ax1, ax0 - bx1))
    dy = np.maximum(0.0, np.maximum(by0 - ay1, ay0 - by1))
    return np.hypot(dx, dy)


@predicate("near", 2, "the actors' footprints are at most `distance` [m] apart", domains=DOM,
           params={"distance": 0.4})
def _near(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _gap(trace, args[0], args[1]) <= float(params.get("distance", 0.4))


@predicate("left_of", 2, "seen from the robot, the first actor is left of the second (+y)", domains=DOM)
def _left_of(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _box(trace, args[0])[2] >= _box(trace, args[1])[3] - TOL


@predicate("right_of", 2, "seen from the robot, the first actor is right of the second (-y)",
           domains=DOM)
def _right_of(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _box(trace, args[0])[3] <= _box(trace, args[1])[2] + TOL


@predicate("in_front_of", 2, "the first actor is between the second and the robot (smaller x)",
           domains=DOM)
def _in_front_of(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _box(trace, args[0])[1] <= _box(trace, args[1])[0] + TOL


@predicate("behind", 2, "the first actor is beyond the second, seen from the robot (larger x)",
           domains=DOM)
def _behind(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _box(trace, args[0])[0] >= _box(trace, args[1])[1] - TOL


@predicate("outside", 2, "the first actor is on the far side of the second's wall (outside the "
           "door or window)", domains=DOM)
def _outside(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _behind(trace, args, params)


@predicate("out_of_reach", 2, "the first actor is farther than `reach` [m] from the robot (second)",
           domains=DOM, params={"reach": 0.9})
def _out_of_reach(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    a, robot = args
    x0, x1, y0, y1, _, _ = _box(trace, a)
    rx, ry = arr(trace, robot, "x"), arr(trace, robot, "y")
    dx = np.maximum(0.0, np.maximum(x0 - rx, rx - x1))
    dy = np.maximum(0.0, np.maximum(y0 - ry, ry - y1))
    return np.hypot(dx, dy) >= float(params.get("reach", 0.9))


@predicate("moved", 1, "the actor is at least `distance` [m] (planar) from where it started",
           domains=DOM, params={"distance": 0.2})
def _moved(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    x, y = arr(trace, args[0], "x"), arr(trace, args[0], "y")
    return np.hypot(x - x[0], y - y[0]) >= float(params.get("distance", 0.2))


@predicate("resting", 1, "the actor is (almost) still: planar speed below `max_speed` [m/s]",
           domains=DOM, params={"max_speed": 0.02})
def _resting(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return arr(trace, args[0], "speed") <= float(params.get("max_speed", 0.02))
