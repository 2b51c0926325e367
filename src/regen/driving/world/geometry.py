"""Oriented boxes in the plane: corners, overlap, gaps, an open door's footprint (numpy).

A box is its centre (x, y) [m], heading [rad] counter-clockwise from +x, ``length`` [m] along
the heading and ``width`` [m] across it. Every function takes scalars or arrays of one shape
(one value per step, say) and returns values of that shape; a single box's corners are a
(4, 2) array. The collision check of a trace (:mod:`regen.driving.verify.collisions`), the gym's
step-by-step check (:mod:`regen.driving.gym.env`), the policies and the pictures
(:mod:`regen.driving.render.actors`) all measure boxes here.
"""

from __future__ import annotations

import numpy as np

DOOR_WIDTH = 1.0  # [m] an open car door sticks out this far from the car's left side


def to_world(x, y, heading, along, across) -> tuple[np.ndarray, np.ndarray]:
    """The map point [m] ``along`` the heading and ``across`` it (to the left) from (x, y)."""
    c, s = np.cos(heading), np.sin(heading)
    return x + along * c - across * s, y + along * s + across * c


def to_local(x, y, heading, px, py) -> tuple[np.ndarray, np.ndarray]:
    """Point (px, py) [m] in the frame at (x, y) facing ``heading``: (ahead, to the left) [m]."""
    c, s = np.cos(heading), np.sin(heading)
    dx, dy = np.subtract(px, x), np.subtract(py, y)
    return dx * c + dy * s, -dx * s + dy * c


def corners(x, y, heading, length, width, *, along=0.0, across=0.0) -> np.ndarray:
    """(..., 4, 2) corners [m] of the box, counter-clockwise from the front left; with
    ``along``/``across`` [m] the box's centre is moved that far in its own frame first."""
    ox, oy = to_world(x, y, heading, along, across)
    out = []
    for lo, la in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        px, py = to_world(ox, oy, heading, lo * length / 2, la * width / 2)
        out.append(np.stack(np.broadcast_arrays(px, py), axis=-1))
    return np.stack(out, axis=-2)


def overlap(xa, ya, ha, la, wa, xb, yb, hb, lb, wb) -> np.ndarray:
    """Do boxes a and b overlap (separating-axis test; touching counts)?"""
    xa, ya, ha, xb, yb, hb = (np.asarray(v, dtype=float) for v in (xa, ya, ha, xb, yb, hb))
    d = np.stack(np.broadcast_arrays(xb - xa, yb - ya), axis=-1)
    axes_a = [np.stack([np.cos(ha), np.sin(ha)], -1), np.stack([-np.sin(ha), np.cos(ha)], -1)]
    axes_b = [np.stack([np.cos(hb), np.sin(hb)], -1), np.stack([-np.sin(hb), np.cos(hb)], -1)]
    out = np.ones(d.shape[:-1], dtype=bool)
    for axis in axes_a + axes_b:
        ra = sum(e * np.abs(np.sum(ax * axis, -1)) for e, ax in zip((la / 2, wa / 2), axes_a, strict=True))
        rb = sum(e * np.abs(np.sum(ax * axis, -1)) for e, ax in zip((lb / 2, wb / 2), axes_b, strict=True))
        out &= np.abs(np.sum(d * axis, -1)) <= ra + rb
    return out


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance [m] from points p to segments ab; all (..., 2)."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0.0, 1.0)
    d = p - (a + t[..., None] * ab)
    return np.hypot(d[..., 0], d[..., 1])


def gap(ca: np.ndarray, cb: np.ndarray, overlapping=False) -> np.ndarray:
    """Distance [m] between two boxes given by their corners (..., 4, 2); 0 where
    ``overlapping`` (the :func:`overlap` of the two), which the corners alone do not tell."""
    best = np.full(ca.shape[:-2], np.inf)
    for p_set, q_set in ((ca, cb), (cb, ca)):
        for i in range(4):
            for j in range(4):
                best = np.minimum(best, _point_segment(p_set[..., i, :], q_set[..., j, :],
                                                       q_set[..., (j + 1) % 4, :]))
    return np.where(overlapping, 0.0, best)


def door_footprint(x, y, heading, width, door_open) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre (x, y) [m] and width [m] of a car's footprint grown by ``DOOR_WIDTH`` on its left
    side where ``door_open`` (bool per step); unchanged where the door is shut."""
    shift = np.where(door_open, DOOR_WIDTH / 2, 0.0)
    return x - shift * np.sin(heading), y + shift * np.cos(heading), width + 2 * shift


__all__ = ["DOOR_WIDTH", "corners", "door_footprint", "gap", "overlap", "to_local", "to_world"]
