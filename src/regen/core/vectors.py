"""Numbers from outside (an agent's action, a user's policy): checked once, with one error."""

from __future__ import annotations

import numpy as np


def _shown(value: object, limit: int = 80) -> str:
    try:
        text = repr(value)
    except Exception:  # a hostile __repr__ must not hide the real problem
        text = f"a {type(value).__name__}"
    return text if len(text) <= limit else text[:limit - 3] + "..."


def finite_vector(value: object, size: int, what: str) -> np.ndarray:
    """``value`` as ``size`` finite float64 numbers [any unit]. ValueError naming ``what`` for
    anything else: strings, None, nested or ragged lists, NaN, infinities and integers too large
    for a float (for which numpy would raise TypeError or OverflowError, or convert a string)."""
    try:
        raw = np.asarray(value)
        ok = raw.dtype.kind in "biuf"  # bool, int, unsigned, float: not str, bytes, object, complex
        vec = raw.astype(np.float64).reshape(-1) if ok else None
    except (TypeError, ValueError, OverflowError):
        vec = None
    if vec is None or vec.shape != (size,) or not np.all(np.isfinite(vec)):
        raise ValueError(f"{what} must be {size} finite numbers, got {_shown(value)}")
    return vec


__all__ = ["finite_vector"]
