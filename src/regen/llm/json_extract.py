"""Pull the JSON object out of a model's answer text (code fences and chatter around it)."""

from __future__ import annotations

import json
import math
from typing import Any

#: Deepest nesting an answer may have [levels]; answer schemas are flat, so deeper is malformed
#: (and deeper still would exhaust the parser's recursion).
MAX_DEPTH = 32
#: How many ``{`` / ``[`` positions are tried as the start of the JSON (each try may read to
#: the end of the text, so this bounds the work on a long broken answer).
MAX_STARTS = 16


def _no_constant(name: str) -> float:
    raise ValueError(f"the answer contains {name}, not a finite number")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"the answer contains {text}, not a finite number")
    return value


_DECODER = json.JSONDecoder(parse_constant=_no_constant, parse_float=_finite)


def _too_deep(value: Any) -> bool:
    stack = [(value, 1)]
    while stack:
        v, depth = stack.pop()
        if isinstance(v, dict | list):
            if depth > MAX_DEPTH:
                return True
            stack.extend((x, depth + 1) for x in (v.values() if isinstance(v, dict) else v))
    return False


def _checked(value: Any) -> Any:
    if _too_deep(value):
        raise ValueError(f"the answer is nested too deeply (more than {MAX_DEPTH} levels)")
    return value


def extract_json(text: str) -> Any:
    """Parse the first complete JSON object or array in ``text``.

    Raise ValueError (a malformed answer) if there is none, if it is nested deeper than
    :data:`MAX_DEPTH`, or if it holds NaN or an infinite number."""
    stripped = text.strip()
    try:
        return _checked(_DECODER.decode(stripped))
    except json.JSONDecodeError:
        pass
    except RecursionError:
        raise ValueError(f"the answer is nested too deeply (more than {MAX_DEPTH} levels)") from None
    tries = 0
    for i, ch in enumerate(stripped):
        if ch not in "{[":
            continue
        tries += 1
        if tries > MAX_STARTS:
            break
        try:
            value, _ = _DECODER.raw_decode(stripped, i)
        except json.JSONDecodeError:
            continue
        except RecursionError:
            raise ValueError(f"the answer is nested too deeply (more than {MAX_DEPTH} levels)") from None
        return _checked(value)
    raise ValueError("the answer contains no JSON object")
