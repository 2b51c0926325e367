"""The aisle domain's own predicate (the shared ones, e.g. stopped and close_to, hold too)."""

from __future__ import annotations

import numpy as np

from regen.verify.predicates import arr, predicate


@predicate("in_aisle", 1, "the actor's centre is inside the aisle (|y| < 0.6 m)", domains=("aisle",))
def _in_aisle(trace, args, params) -> np.ndarray:
    return np.abs(arr(trace, args[0], "y")) < 0.6
