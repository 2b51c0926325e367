"""Defensive readers: a missing or broken file gives a :class:`Loaded` with the problem, never an
exception, so a half-finished or hand-edited run can still be shown."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

M = TypeVar("M", bound=BaseModel)

MAX_JSON_BYTES = 50_000_000  # larger files are not parsed by readers (a trace can be big)
MAX_TEXT_CHARS = 20_000  # error.txt beyond this is cut when read for display



@dataclass
class Loaded:
    """The outcome of reading one file: the value, or why there is none."""

    value: Any = None
    problem: str | None = None  # 'missing' or 'unreadable: ...'

    @property
    def ok(self) -> bool:
        return self.problem is None


def _short(exc: BaseException, limit: int = 200) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    return msg if len(msg) <= limit else msg[:limit] + "..."


def read_json(path: Path) -> Loaded:
    """Parse a JSON file; a missing, oversized or broken file gives a problem, not an exception."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            return Loaded(problem=f"unreadable: larger than {MAX_JSON_BYTES // 1_000_000} MB")
        return Loaded(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_model(path: Path, model: type[M], key: str | None = None) -> Loaded:
    """Read a JSON file (or its ``key`` member) as a pydantic model."""
    raw = read_json(path)
    if not raw.ok:
        return raw
    data = raw.value
    if key is not None:
        if not isinstance(data, dict) or key not in data:
            return Loaded(problem=f"unreadable: no {key!r} member")
        data = data[key]
    try:
        return Loaded(model.model_validate(data))
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ()))
        return Loaded(problem=f"unreadable: {where or 'value'}: {first.get('msg', 'invalid')}"
                              f" ({exc.error_count()} error(s))")
    except Exception as exc:  # model validators may raise domain errors (e.g. GraphCycleError)
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_text(path: Path, limit: int = MAX_TEXT_CHARS) -> Loaded:
    """Read a text file, cut to ``limit`` characters (a note says how much was left out)."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")
    if len(text) > limit:
        text = text[:limit] + f"\n[... {len(text) - limit} more characters in the file]"
    return Loaded(text)


__all__ = ["MAX_JSON_BYTES", "MAX_TEXT_CHARS", "Loaded", "read_json", "read_model", "read_text"]
