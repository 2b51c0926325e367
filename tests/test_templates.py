"""regen.templates: one loader; the caller chooses escaping, undefined names always fail."""

from __future__ import annotations

import jinja2
import pytest

from regen.templates import environment, render


def test_prompts_are_plain_text_and_stripped():
    # a prompt quotes the model's words as they are: no HTML escaping of '<' or '&'
    text = render("regen.expand", "system", wording=_Wording())
    assert "<robots & cars>" in text
    assert text == text.strip()


def test_html_escapes_what_it_inserts():
    env = environment("regen.report", "templates", html=True)
    assert env.from_string("{{ v }}").render(v="<b>&</b>") == "&lt;b&gt;&amp;&lt;/b&gt;"
    assert environment("regen.expand").from_string("{{ v }}").render(v="<b>") == "<b>"


@pytest.mark.parametrize("html", [False, True])
def test_an_undefined_name_is_an_error(html):
    with pytest.raises(jinja2.UndefinedError):
        environment("regen.report", "templates", html=html).from_string("{{ typo }}").render()


def test_the_scenic_program_keeps_its_last_newline():
    from regen.driving.simulation.program import _template

    assert _template().environment.keep_trailing_newline
    assert not environment("regen.expand").keep_trailing_newline


class _Wording:
    expert = "<robots & cars>"
    situation = cause_rule = value_hint = ""
    judge_examples = ()
    mechanics = ()
