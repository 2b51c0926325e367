"""Text hygiene, in one place: the characters no output of the toolkit may carry.

C0 controls but tab, newline and carriage return; DEL and C1 controls; the bidirectional
embedding, override and isolate controls (U+202A-U+202E, U+2066-U+2069), which reorder what a
terminal or a page shows ("Trojan Source"), and every other invisible format character (Unicode
category Cf: U+200B zero width space, U+200E/U+200F direction marks, U+2060 word joiner, U+FEFF,
the U+E0000 tag characters that can smuggle whole invisible sentences to a model ...), which make
two texts that look the same differ; lone surrogates (half an emoji from a ``\\ud83d``
JSON escape). The two join controls U+200C and U+200D stay: they are part of how emoji
sequences and several scripts (Persian, Indic) are written, and reorder or hide nothing. HTML forbids the controls, terminals obey them (moving the
cursor, clearing the screen), and a lone surrogate cannot be written as UTF-8 at all: one in a
narrative would cost a whole page or file.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

_CONTROL = "\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f"  # Cc but tab, newline, carriage return
_BIDI = "\u202a-\u202e\u2066-\u2069"  # bidi embeddings, overrides and isolates
# Unicode category Cf (as of Unicode 15) but the join controls U+200C, U+200D; written out
# rather than computed, so importing this costs nothing (tests/core/test_text.py checks it
# against the running Python's unicodedata)
_FORMAT = ("\u00ad\u0600-\u0605\u061c\u06dd\u070f\u0890\u0891\u08e2\u180e\u200b\u200e\u200f"
           "\u202a-\u202e\u2060-\u2064\u2066-\u206f\ufeff\ufff9-\ufffb\U000110bd\U000110cd"
           "\U00013430-\U0001343f\U0001bca0-\U0001bca3\U0001d173-\U0001d17a\U000e0001"
           "\U000e0020-\U000e007f")
_SURROGATE = "\ud800-\udfff"  # in a str these are always unpaired
CONTROL = re.compile(f"[{_CONTROL}]")
BIDI = re.compile(f"[{_BIDI}]")
FORMAT = re.compile(f"[{_FORMAT}]")  # invisible format characters, the bidi controls among them
SURROGATE = re.compile(f"[{_SURROGATE}]")
UNSAFE = re.compile(f"[{_CONTROL}{_FORMAT}{_SURROGATE}]")  # any of them


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
    """``text`` with its unsafe characters written as ``\\uXXXX`` escapes, for quoting in messages."""
    return UNSAFE.sub(lambda m: f"\\u{ord(m.group()):04x}", text)
