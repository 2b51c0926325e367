"""Model answers made safe once, where they enter the toolkit.

A model, or a server in front of it, can send what no later stage expects: lone UTF-16
surrogates (``"\\ud800"``, which SQLite and every UTF-8 file writer refuse), control characters
(NUL, terminal escapes) and megabytes in one string. The client passes every answer text
through :func:`clean_text` before it is cached, and every parsed answer through
:func:`clean_value` before it is validated, so stages after the LLM layer never see them.
"""

from __future__ import annotations

from typing import Any

from regen.core.text import CONTROL, FORMAT, SURROGATE, map_strings

#: Longest model-written string (a reason, label, narrative, name) [characters]; longer ones are
#: cut to this length, ending in an ellipsis. Labels have tighter limits in their answer schemas.
MAX_TEXT_CHARS = 500
ELLIPSIS = "\u2026"
REPLACEMENT = "\ufffd"

# regen.core.text: Unicode control characters but tab, newline and carriage return (answer text
# keeps \r, whitespace between JSON tokens; strings of a parsed answer lose it too), invisible
# format characters (the bidi controls, zero-width spaces, direction marks, tag characters ...;
# not the join controls U+200C, U+200D), and lone surrogates.


def clean_text(text: str) -> str:
    """An answer text as received: lone surrogates become U+FFFD, control characters other
    than tab, newline and carriage return are removed, and so are invisible format characters
    (:data:`regen.core.text.FORMAT`: bidi controls, U+200B, U+200F, U+FEFF ...)."""
    return FORMAT.sub("", CONTROL.sub("", SURROGATE.sub(REPLACEMENT, text)))


def clean_string(text: str, limit: int = MAX_TEXT_CHARS) -> str:
    """One string of a parsed answer: cleaned like :func:`clean_text` (carriage returns too)
    and cut to ``limit`` characters, the last being an ellipsis."""
    text = FORMAT.sub("", CONTROL.sub("", SURROGATE.sub(REPLACEMENT, text))).replace("\r", "")
    return text if len(text) <= limit else text[:limit - 1] + ELLIPSIS


def clean_value(value: Any) -> Any:
    """A parsed JSON answer with every string (keys too) passed through :func:`clean_string`.

    The nesting is bounded by :func:`regen.llm.json_extract.extract_json`."""
    return map_strings(value, clean_string)


def shorten(text: str, limit: int) -> str:
    """``text`` cut to ``limit`` characters for a message (an echo or an error)."""
    return text if len(text) <= limit else text[:limit - 1] + ELLIPSIS
