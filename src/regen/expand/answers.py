"""What the model may answer during graph expansion (validated; never executed)."""

from __future__ import annotations

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


class EdgeDecision(Answer):
    candidate: str
    plausible: bool
    reason: str = ""


class EdgeJudgement(Answer):
    decisions: list[EdgeDecision] = Field(default_factory=list)


class EntityChoice(Answer):
    name: str
    reason: str = ""


class EntitySelection(Answer):
    entities: list[EntityChoice] = Field(default_factory=list)


class ValueProposal(Answer):
    values: list[str] = Field(default_factory=list)

    @field_validator("values")
    @classmethod
    def _tidy(cls, v: list[str]) -> list[str]:
        return [c for c in (_clean(x) for x in v) if c and len(c) <= 120]


class PropertyChoice(Answer):
    property: str
    values: list[str] = Field(default_factory=list)
    reason: str = ""


class PropertySelection(Answer):
    choices: list[PropertyChoice] = Field(default_factory=list)
