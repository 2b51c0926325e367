"""What the model may answer during graph expansion (validated; never executed)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator

from regen.core.base import Answer


def _clean(text: str) -> str:
    return " ".join(str(text).split()).strip(" .-*•\"'")


class EventProposal(Answer):
    causes: list[str] = Field(default_factory=list)

    @field_validator("causes")
    @classmethod
    def _tidy(cls, v: list[str]) -> list[str]:
        out = [_clean(c) for c in v]
        return [c for c in out if c and len(c) <= 200]


class EdgeVerdict(Answer):
    """One candidate cause judged: the answer, then its reason (a small model decides better at
    once than after arguing). Both required: constrained decoding writes required fields in this
    order, optional ones last."""

    answer: Literal["yes", "no"]
    reason: str


class YesNo(Answer):
    """A yes/no judgement with no reason (the entity judge: short and decisive)."""

    answer: Literal["yes", "no"]


class EntityChoice(Answer):
    name: str
    reason: str = ""


class EntitySelection(Answer):
    entities: list[EntityChoice] = Field(default_factory=list)
