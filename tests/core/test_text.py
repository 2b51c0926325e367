"""Invisible format characters (Unicode Cf) leave user and model text at every cleaning point."""

from __future__ import annotations

import sys
import unicodedata

import pytest

from regen.core.behavior import Behavior
from regen.core.text import UNSAFE, clean, escaped
from regen.expand.expansion import _tidy
from regen.llm import LLM
from regen.llm.sanitize import clean_string, clean_text
from regen.llm.testing import QueuedProvider

JOINERS = {"\u200c", "\u200d"}  # join controls: part of emoji sequences and scripts, kept

# what a pasted text or a model answer carries: zero width space, right-to-left mark, left-to-
# right mark, word joiner, BOM, soft hyphen, an invisible tag sentence (ASCII smuggling)
HIDDEN = ["\u200b", "\u200f", "\u200e", "\u2060", "\ufeff", "\u00ad", "\U000e0041\U000e0042"]


def test_the_format_class_is_every_cf_character_but_the_join_controls() -> None:
    from regen.core.text import FORMAT

    cf = {chr(c) for c in range(sys.maxunicode + 1) if unicodedata.category(chr(c)) == "Cf"}
    matched = {chr(c) for c in range(sys.maxunicode + 1) if FORMAT.match(chr(c))}
    assert cf - JOINERS <= matched
    # beyond this Python's Unicode tables only characters later versions made Cf
    assert all(unicodedata.category(c) in ("Cf", "Cn") for c in matched) and not matched & JOINERS


@pytest.mark.parametrize("hidden", HIDDEN)
def test_every_cleaning_point_removes_invisible_characters(hidden: str) -> None:
    text = f"a pedestrian{hidden} crosses"
    assert clean(text) == "a pedestrian crosses"
    assert clean_text(text) == "a pedestrian crosses"
    assert clean_string(text) == "a pedestrian crosses"
    assert _tidy([text]) == ["a pedestrian crosses"]
    assert Behavior(text=f"the ego{hidden} stops", domain="driving").text == "the ego stops"
    assert UNSAFE.search(text) and "\\u" in escaped(text)


def test_model_answers_lose_them_before_validation_and_caching(tmp_path) -> None:
    from regen.core.base import Answer

    class Found(Answer):
        causes: list[str]

    llm = LLM(QueuedProvider(['\ufeff{"causes": ["debris\u200b on the\u200f road"]}']),
              cache=tmp_path / "c.sqlite")
    assert llm.structured("q", Found).causes == ["debris on the road"]


def test_join_controls_stay() -> None:
    family = "\U0001f468\u200d\U0001f469"
    persian = "\u0645\u06cc\u200c\u062e\u0648\u0627\u0647\u0645"
    for text in (family, persian):
        assert clean(text) == clean_text(text) == _tidy([text])[0] == text
