"""Printing model or file text to a terminal: nothing in it may move the cursor, start a line,
reorder or hide what is shown.

The character classes here are the toolkit's one definition of unsafe text
(:mod:`regen.core.text` cleans with them):

- C0 controls but tab, newline and carriage return; DEL and C1 controls (U+0085 NEL among them);
- the bidirectional embedding, override and isolate controls (U+202A-U+202E, U+2066-U+2069),
  which reorder what a terminal or a page shows ("Trojan Source"), and every other invisible
  format character (Unicode category Cf: U+200B zero width space, U+200E/U+200F direction
  marks, U+2060 word joiner, U+FEFF, the U+E0000 tag characters that can smuggle whole
  invisible sentences to a model ...). The two join controls U+200C and U+200D are not among
  them: they are part of how emoji sequences and several scripts (Persian, Indic) are written,
  and reorder or hide nothing;
- lone surrogates (half an emoji from a ``\\ud83d`` JSON escape), which cannot be written as
  UTF-8 at all.

A line printed for a user may carry none of these, nor a line break of any kind: tab, newline,
carriage return and the Unicode line and paragraph separators U+2028, U+2029 would let a model
answer or a file start a line of its own that looks like the toolkit's (``error: ...``).
:func:`printable` shows every such character as an escape (``\\n``, ``\\u2028``), so the text
can be read as it was, on one line.
"""

from __future__ import annotations

import re

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
_BREAKS = "\t\n\r\u2028\u2029"  # tab, line breaks, line and paragraph separators (NEL, VT, FF are Cc)

CONTROL = re.compile(f"[{_CONTROL}]")
BIDI = re.compile(f"[{_BIDI}]")
FORMAT = re.compile(f"[{_FORMAT}]")  # invisible format characters, the bidi controls among them
SURROGATE = re.compile(f"[{_SURROGATE}]")
UNSAFE = re.compile(f"[{_CONTROL}{_FORMAT}{_SURROGATE}]")  # any of them
BREAKS = re.compile(f"[{_BREAKS}]")
#: What a terminal line may not carry as it is: :data:`UNSAFE` and every line break.
NOT_PRINTABLE = re.compile(f"[{_CONTROL}{_FORMAT}{_SURROGATE}{_BREAKS}]")

_SHORT = {"\t": "\\t", "\n": "\\n", "\r": "\\r"}


def escape_char(char: str) -> str:
    """One character as an escape: ``\\n``, ``\\t``, ``\\r``, else ``\\u`` and its code point
    in (at least four) hex digits."""
    return _SHORT.get(char) or f"\\u{ord(char):04x}"


def escaped(text: str, chars: re.Pattern[str] = NOT_PRINTABLE) -> str:
    """``text`` with every character ``chars`` matches written as an escape (:func:`escape_char`)."""
    return chars.sub(lambda m: escape_char(m.group()), text)


def printable(value: object) -> str:
    """``value`` as text for one terminal line: controls, line breaks (U+2028 and U+2029
    included), bidi and other invisible format characters and lone surrogates shown escaped.
    Markup of a terminal library (Rich's ``[red]``) is the caller's to escape."""
    return escaped(str(value))


__all__ = ["BIDI", "BREAKS", "CONTROL", "FORMAT", "NOT_PRINTABLE", "SURROGATE", "UNSAFE", "escape_char",
           "escaped", "printable"]
