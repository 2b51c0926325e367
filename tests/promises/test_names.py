"""Names on disk from user or model text: a safe name is one plain entry of its folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from regen.errors import ConfigError
from regen.promises.names import MAX_NAME_CHARS, child, problem, safe_name, slug


@pytest.mark.parametrize(("text", "why"), [
    ("..", "names a folder itself"),
    (".", "names a folder itself"),
    ("../x", "path separator"),
    ("/etc/x", "absolute path"),
    ("C:\\temp", "absolute path"),
    ("a/b", "path separator"),
    ("a\\b", "path separator"),
    ("x" * 300, f"longer than {MAX_NAME_CHARS}"),
    ("\u00e9" * 130, f"longer than {MAX_NAME_CHARS}"),  # 260 bytes of UTF-8
    ("a\x00b", "control"),
    ("a\nb", "line-break"),
    ("a\u2028b", "line-break"),
    ("evil\u202egnp.exe", "invisible"),
    ("a\ud800", "invisible"),
    ("", "empty"),
    ("   ", "empty"),
    (".hidden", "starts with a dot"),
    (" padded", "space"),
])
def test_what_cannot_name_a_folder_is_refused_on_one_line(text: str, why: str) -> None:
    assert why in (problem(text) or "")
    with pytest.raises(ConfigError) as got:
        safe_name(text, what="the case id")
    message = str(got.value)
    assert message.startswith("the case id '") and why in message and "give a plain name" in message
    assert "\n" not in message and "\x00" not in message and "\u2028" not in message
    assert len(message) < 300  # a 300-character name is quoted shortened


@pytest.mark.parametrize("text", ["case-01", "stop_abruptly.v2", "Fall 3", "\u00e9t\u00e9", "x" * MAX_NAME_CHARS])
def test_a_plain_name_is_kept_as_it_is(text: str) -> None:
    assert problem(text) is None and safe_name(text) == text


def test_child_stays_inside_its_folder(tmp_path: Path) -> None:
    assert child(tmp_path, "case-1") == tmp_path / "case-1"
    for bad in ("../x", "/etc/passwd", "a/../../b"):
        with pytest.raises(ConfigError):
            child(tmp_path, bad)


@pytest.mark.parametrize(("text", "want"), [
    ("A child runs across the road!", "a-child-runs-across-the-road"),
    ("../../etc/passwd", "etc-passwd"),
    ("/abs/path", "abs-path"),
    ("\u2028\x00\u202e", "item"),
    ("", "item"),
    ("x" * 300, "x" * 40),
])
def test_slug_makes_any_text_a_safe_name(text: str, want: str) -> None:
    got = slug(text)
    assert got == want and problem(got) is None


def test_slug_is_bounded_and_never_ends_in_a_dash() -> None:
    assert slug("a " * 100, limit=10) == "a-a-a-a-a"
    assert slug("???", fallback="scenario") == "scenario"
