"""Text hygiene, in one place: the characters no output of the toolkit may carry.

The character classes are defined by :mod:`regen.promises.terminal` (C0 and C1 controls but
tab, newline and carriage return; the bidi controls and every other invisible format character
but the join controls U+200C, U+200D; lone surrogates): HTML forbids the controls, terminals obey
them (moving the cursor, clearing the screen), and a lone surrogate cannot be written as UTF-8
at all: one in a narrative would cost a whole page or file. This module cleans user and model
text with them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from regen.promises import terminal
from regen.promises.terminal import BIDI, CONTROL, FORMAT, SURROGATE, UNSAFE


def clean(text: str) -> str:
    """``text`` without unsafe characters."""
    return UNSAFE.sub("", text)


def one_line(text: str) -> str:
    """User text (a behavior, a cause, a prior) as one line: invisible format characters
    removed, control characters and runs of whitespace made one space. Lone surrogates stay
    (undecodable bytes of a command-line argument; :func:`clean` drops them for display)."""
    return " ".join(FORMAT.sub("", CONTROL.sub(" ", text)).split())


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
    """``text`` with its unsafe characters written as ``\\uXXXX`` escapes, for quoting in messages
    (line breaks stay; :func:`regen.promises.terminal.printable` escapes those too)."""
    return terminal.escaped(text, UNSAFE)


__all__ = ["BIDI", "CONTROL", "FORMAT", "SURROGATE", "UNSAFE", "clean", "clean_data", "escaped", "map_strings",
           "one_line"]
