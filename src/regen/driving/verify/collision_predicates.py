"""Collision predicates (oriented-box overlap from :mod:`regen.driving.verify.collisions`).

Imported by :mod:`regen.driving.verify.predicates`, so they are in the driving library wherever the
others are.
"""

from __future__ import annotations

import numpy as np

from regen.core.trace import Trace
from regen.driving.verify.collisions import checked_pairs, footprint, overlap
from regen.verify.predicates import arr, predicate

D = ("driving",)


def _pair_overlap(trace: Trace, a: str, b: str) -> np.ndarray:
    ta, tb = trace.actors[a], trace.actors[b]
    ha, hb = arr(trace, a, "heading"), arr(trace, b, "heading")
    xa, ya, wa = footprint(ta, arr(trace, a, "x"), arr(trace, a, "y"), ha)
    xb, yb, wb = footprint(tb, arr(trace, b, "x"), arr(trace, b, "y"), hb)
    return overlap(xa, ya, ha, ta.length, wa, xb, yb, hb, tb.length, wb)


@predicate("collides", 2, "the footprints (oriented boxes) of a and b overlap", domains=D)
def _collides(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    return _pair_overlap(trace, args[0], args[1])


@predicate("collision", 1, "the actor's footprint overlaps any other road user or object "
           "(vehicle-vehicle, vehicle-pedestrian, vehicle-static object)", domains=D)
def _collision(trace: Trace, args: list[str], params: dict) -> np.ndarray:
    out = np.zeros(trace.steps, dtype=bool)
    for a, b in checked_pairs(trace):
        if args[0] in (a, b):
            out |= _pair_overlap(trace, a, b)
    return out
