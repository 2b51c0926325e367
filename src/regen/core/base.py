"""Pydantic base classes shared by the data model."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Model(BaseModel):
    """Strict input model: unknown keys are an error, so typos in user files surface."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)


class Answer(BaseModel):
    """Base for schemas the LLM fills. Unknown keys are an error too (re-asked), and the
    schema is kept small and flat so that small local models can follow it."""

    model_config = ConfigDict(extra="forbid")
