"""A real call to the offline default model (deselect with -m 'not model'; CI runs it)."""

from __future__ import annotations

import pytest

from regen.core.base import Answer

pytestmark = [pytest.mark.model, pytest.mark.usefixtures("shared_cache")]


class Causes(Answer):
    causes: list[str]


def test_offline_model_returns_a_schema_valid_answer() -> None:
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    from regen.llm import LLM

    llm = LLM("local")
    got = llm.ask("List two plausible causes why a car driving forward on a road stops abruptly. "
                  'Answer as JSON: {"causes": ["...", "..."]}', Causes, purpose="smoke")
    assert isinstance(got.value, Causes)
    assert len(got.value.causes) >= 1 and all(c.strip() for c in got.value.causes)
    assert llm.stats.total.output_tokens > 0
