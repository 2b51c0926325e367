"""Whether a scenario really played out, and if not, where and why."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from regen.core.base import Model


class StageResult(Model):
    index: int  # 1-based stage number
    conditions: list[str]  # 'actor: state' for each condition
    reached_at: float | None = None  # [s] first time all conditions held (after the previous stage)
    satisfied_alone: dict[str, float | None] = Field(default_factory=dict)  # condition -> first time it held on its own


class Verdict(Model):
    feasible: bool
    status: Literal["verified", "fsm_incomplete", "unsatisfiable", "grounding_failed",
                    "simulation_failed", "invalid_scenario"]
    reason: str
    stages: list[StageResult] = Field(default_factory=list)
    first_unmet_stage: int | None = None  # 1-based
    relaxations: list[str] = Field(default_factory=list)
    conflicts: list[str] = Field(default_factory=list)
