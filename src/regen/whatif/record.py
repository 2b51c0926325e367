"""``whatif.json``: a counterfactual and what it is the counterfactual of (:class:`WhatIf`), and
the FSM stages that changed between the two."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from regen.core.base import Model
from regen.whatif.edits import Edit

if TYPE_CHECKING:
    from regen.core.scenario import Scenario

WHATIF_JSON = "whatif.json"


def stage_lines(scenario: Scenario) -> list[str]:
    """The FSM stages in words: 'child1 waiting and ego driving'."""
    return [" and ".join(f"{c.actor} {c.state}" for c in stage.conditions) for stage in scenario.fsm.stages]


def changed_stages(before: Scenario, after: Scenario | None) -> list[dict[str, str | None]]:
    """Stages that differ, by position: {'index', 'before', 'after'}."""
    a, b = stage_lines(before), stage_lines(after) if after is not None else []
    out = []
    for k in range(max(len(a), len(b))):
        x, y = (a[k] if k < len(a) else None), (b[k] if k < len(b) else None)
        if x != y:
            out.append({"index": str(k + 1), "before": x, "after": y})
    return out


class WhatIf(Model):
    """``whatif.json``: a counterfactual and what it is the counterfactual of."""

    original: str  # the original scenario folder (absolute)
    question: str | None = None  # --ask, when the edits came from the model
    edits: list[Edit]
    edits_by: Literal["user", "model"] = "user"
    call_id: str | None = None  # the model call that wrote the edits
    original_status: str
    status: str  # the counterfactual's verdict
    #: the robot's behavior is still explained: the counterfactual's FSM played out and its cause
    #: caused the behavior (the but-for check with the reference robot, :mod:`regen.verify.causal`;
    #: where the domain cannot check, the FSM alone, and ``causal`` says 'not_checked')
    explained: bool
    causal: str | None = None  # the counterfactual's causal status
    original_causal: str | None = None  # the original's
    #: the event judge on the counterfactual's root cause ({'by', 'plausible', 'reason'}); by
    #: 'none' when no model judged it. Recorded beside the simulation's answer, never over it
    judged: dict[str, Any] = Field(default_factory=lambda: {"by": "none", "plausible": None, "reason": ""})
    original_explained: bool
    reason: str
    stages_changed: list[dict[str, str | None]] = Field(default_factory=list)
    #: For each property an edit set: the states the entity showed in each run, in order of
    #: first appearance ({'entity', 'property', 'before', 'after'}): what the pictures show.
    shown_states: list[dict[str, str]] = Field(default_factory=list)


__all__ = ["WHATIF_JSON", "WhatIf", "changed_stages", "stage_lines"]
