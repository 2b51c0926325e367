"""Links from report.html to files of its run folder, and the plain readers of the JSON values
the report's views are built from (a field of the wrong type reads as missing)."""

from __future__ import annotations

import math
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import quote


def href(*parts: str) -> str:
    """A relative URL to a file in the run folder (each part percent-encoded)."""
    return "/".join(quote(p) for p in parts)


def inside_href(base: Path, value: Any, *prefix: str) -> str | None:
    """href (``prefix`` then the path) of a file a JSON file names relative to its folder
    ``base``, if it is a file inside that folder; None for anything else (an absolute path, a
    step out with '..', a backslash, a missing file)."""
    if not isinstance(value, str) or not value or "\\" in value:
        return None
    rel = PurePosixPath(value)
    if rel.is_absolute() or ".." in rel.parts or not (base / rel).is_file():
        return None
    return href(*prefix, *rel.parts)


def num(value: Any) -> float | None:
    """A finite number, else None (booleans are not numbers here)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def text(value: Any) -> str:
    return value if isinstance(value, str) else ""


__all__ = ["href", "inside_href", "num", "text"]
