"""Test doubles for the LLM layer (for tests only; never the product)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pydantic import BaseModel

from regen.llm.base import Completion, Message, Provider, Sampling


class QueuedProvider(Provider):
    """Answers queued strings (or models, dumped as JSON) in order; records what it was asked."""

    name = "queued"
    #: One at a time, so that queued answers meet their calls in order.
    concurrent = False

    def __init__(self, answers: Iterable[str | BaseModel | dict[str, Any]] = (), model: str = "test"):
        self.model = model
        self.answers: list[str] = [self._text(a) for a in answers]
        self.requests: list[list[Message]] = []

    @staticmethod
    def _text(a: str | BaseModel | dict[str, Any]) -> str:
        import json

        if isinstance(a, BaseModel):
            return a.model_dump_json()
        if isinstance(a, dict):
            return json.dumps(a)
        return a

    def queue(self, *answers: str | BaseModel | dict[str, Any]) -> None:
        self.answers.extend(self._text(a) for a in answers)

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        self.requests.append(list(messages))
        if not self.answers:
            raise AssertionError("QueuedProvider: no answer queued for this call: "
                                 + messages[-1]["content"][:200])
        text = self.answers.pop(0)
        return Completion(text=text, input_tokens=sum(len(m["content"].split()) for m in messages),
                          output_tokens=len(text.split()))


class FunctionProvider(Provider):
    """Answers with ``fn(messages)``: for tests whose answers depend on the prompt."""

    name = "function"

    def __init__(self, fn, model: str = "test"):
        self.fn = fn
        self.model = model
        self.requests: list[list[Message]] = []

    def complete(self, messages: list[Message], *, schema: dict[str, Any] | None,
                 sampling: Sampling) -> Completion:
        self.requests.append(list(messages))
        text = QueuedProvider._text(self.fn(messages))
        return Completion(text=text, input_tokens=10, output_tokens=len(text.split()))
