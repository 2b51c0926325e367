"""Text hygiene, in one place: the characters no output of the toolkit may carry.

C0 controls but tab, newline and carriage return; DEL and C1 controls; the bidirectional
embedding, override and isolate controls (U+202A-U+202E, U+2066-U+2069), which reorder what a
terminal or a page shows ("Trojan Source"); lone surrogates (half an emoji from a ``\\ud83d``
JSON escape). HTML forbids the controls, terminals obey them (moving the
cursor, clearing the screen), and a lone surrogate cannot be written as UTF-8 at all: one in a
narrative would cost a whole page or file.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

_CONTROL = "\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f"  # Cc but tab, newline, carriage return
_BIDI = "\u202a-\u202e\u2066-\u2069"  # bidi embeddings, overrides and isolates
_SURROGATE = "\ud800-\udfff"  # in a str these are always unpaired
CONTROL = re.compile(f"[{_CONTROL}]")
BIDI = re.compile(f"[{_BIDI}]")
SURROGATE = re.compile(f"[{_SURROGATE}]")
UNSAFE = re.compile(f"[{_CONTROL}{_BIDI}{_SURROGATE}]")  # any of the three


def clean(text: str) -> str:
    """``text`` without unsafe characters."""
    return UNSAFE.sub("", text)


def map_strings(value: Any, fn: Callable[[str], str]) -> Any:
    """JSON-like ``value`` with ``fn`` applied to every string in it, keys included."""
    if isinstance(value, str):
        return fn(value)
    if isinstance(value, dict):
        return {map_strings(k, fn): map_strings(v, fn) for k, v in value.items()}
    if isinstance(value, list):
        return [map_strings(v, fn) for v in value]
    return value


def clean_data(value: Any) -> Any:
    """Every string in JSON-like ``value`` (keys included) without unsafe characters."""
    return map_strings(value, clean)


def escaped(text: str) -> str:
    """``text`` with its unsafe characters written as ``\\uXXXX`` escapes, for quoting in messages."""
    return UNSAFE.sub(lambda m: f"\\u{ord(m.group()):04x}", text)
