"""Model or file text on a terminal: nothing in it starts a line, moves the cursor or hides."""

from __future__ import annotations

import pytest

from regen.promises.terminal import NOT_PRINTABLE, UNSAFE, escaped, printable


@pytest.mark.parametrize(("text", "shown"), [
    ("ghost\u2028error: fake", "ghost\\u2028error: fake"),
    ("ghost\u2029error: fake", "ghost\\u2029error: fake"),
    ("a\nerror: b", "a\\nerror: b"),
    ("a\r\nb", "a\\r\\nb"),
    ("tab\there", "tab\\there"),
    ("\x1b[2J\x1b[Hclear", "\\u001b[2J\\u001b[Hclear"),
    ("next\x85line", "next\\u0085line"),
    ("abc\u202edcba", "abc\\u202edcba"),
    ("zero\u200bwidth", "zero\\u200bwidth"),
    ("half \ud83d emoji", "half \\ud83d emoji"),
    ("tag\U000e0041", "tag\\ue0041"),
])
def test_what_a_terminal_obeys_is_shown_escaped(text: str, shown: str) -> None:
    out = printable(text)
    assert out == shown
    assert not NOT_PRINTABLE.search(out) and len(out.splitlines()) == 1
    out.encode("utf-8")  # a lone surrogate would make the console raise


def test_readable_text_is_kept() -> None:
    text = "a pedestrian crosses \u2014 caf\u00e9, \U0001f468\u200d\U0001f469, \u0645\u06cc\u200c\u062e"
    assert printable(text) == text


def test_the_message_escape_keeps_line_breaks() -> None:
    # core.text.escaped quotes unsafe characters in messages that are joined to one line later
    assert escaped("a\n\x00b", UNSAFE) == "a\n\\u0000b"
    assert printable(12) == "12"
