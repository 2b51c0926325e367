"""Feature statistics as LeRobot keeps them (``meta/stats.json`` and the episodes' ``stats/*``
columns): ``min``, ``max``, ``mean``, ``std``, ``count`` and the quantiles ``q01`` .. ``q99``.

Per episode they are exact (over every frame; a picture's over its pixels, per channel, scaled
to [0, 1] and shaped (3, 1, 1)). The dataset's are merged from the episodes' as LeRobot's
``aggregate_stats`` merges them: exact min, max, mean, std and count, the quantiles weighted by
each episode's frames.
"""

from __future__ import annotations

from typing import Any

import numpy as np

QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
Q_KEYS = tuple(f"q{int(round(q * 100)):02d}" for q in QUANTILES)


def feature_stats(values: Any, images: list[np.ndarray] | None = None) -> dict[str, list]:
    """Stats of one episode's column: (n,) or (n, d) numbers, or its pictures ((h, w, 3) uint8
    each, passed as ``images``)."""
    if images is not None:
        px = np.stack(images).reshape(-1, 3).astype(np.float64) / 255.0
        stats = _stats(px)
        out = {k: [[[v]] for v in vals] for k, vals in stats.items()}  # (3, 1, 1)
        out["count"] = [len(images)]
        return out
    arr = np.asarray(values, dtype=np.float64)
    arr = arr.reshape(len(arr), -1)
    out = {k: list(v) for k, v in _stats(arr).items()}
    out["count"] = [len(arr)]
    return out


def _stats(arr: np.ndarray) -> dict[str, list[float]]:
    out = {"min": arr.min(axis=0), "max": arr.max(axis=0), "mean": arr.mean(axis=0), "std": arr.std(axis=0)}
    for key, q in zip(Q_KEYS, QUANTILES, strict=True):
        out[key] = np.quantile(arr, q, axis=0)
    return {k: [float(x) for x in v] for k, v in out.items()}


def merge_stats(episodes: list[dict[str, dict[str, list]]]) -> dict[str, dict[str, list]]:
    """The dataset's stats from its episodes' (each ``{feature: {stat: values}}``)."""
    merged: dict[str, dict[str, list]] = {}
    for key in episodes[0]:
        parts = [ep[key] for ep in episodes]
        counts = np.array([p["count"][0] for p in parts], dtype=np.float64)
        w = counts / counts.sum()

        def arr(stat: str, parts=parts) -> np.ndarray:
            return np.array([p[stat] for p in parts], dtype=np.float64)

        mean = np.tensordot(w, arr("mean"), axes=1)
        var = np.tensordot(w, arr("std") ** 2 + (arr("mean") - mean) ** 2, axes=1)
        out = {"min": arr("min").min(axis=0), "max": arr("max").max(axis=0), "mean": mean,
               "std": np.sqrt(np.maximum(var, 0.0))}
        for q in Q_KEYS:
            out[q] = np.tensordot(w, arr(q), axes=1)
        merged[key] = {k: v.tolist() for k, v in out.items()}
        merged[key]["count"] = [int(counts.sum())]
    return merged


__all__ = ["QUANTILES", "feature_stats", "merge_stats"]
