"""Whether a scenario really played out, and if not, where and why."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from regen.core.base import Model


class StageResult(Model):
    index: int  # 1-based stage number
    conditions: list[str]  # 'actor: state' for each condition
    reached_at: float | None = None  # [s] first time all conditions held (after the previous stage)
    satisfied_alone: dict[str, float | None] = Field(default_factory=dict)  # condition -> first time it held on its own


VerdictStatus = Literal["verified", "verified_after_relaxation", "cause_not_shown", "fsm_incomplete",
                        "unsatisfiable", "ungroundable", "grounding_failed", "simulation_failed",
                        "invalid_scenario", "unfaithful"]
#: The statuses of a scenario that played out (``feasible`` is true exactly for these).
FEASIBLE_STATUSES: tuple[str, ...] = ("verified", "verified_after_relaxation")


class Fidelity(Model):
    """Whether a scenario shows what its cause's words name (its entities and their states).

    ``unfaithful``: the text names something the scenario does not show (a traffic signal, and
    the scenario shows a traffic cone; an ambulance let pass, and its siren is off).
    ``undecided``: the text names nothing rules can compare and no model was asked."""

    status: Literal["faithful", "unfaithful", "undecided"]
    by: Literal["rule", "model"] = "rule"
    reason: str = ""
    named: list[str] = Field(default_factory=list)  # what the cause text names ('traffic_light', 'siren = on')
    shown: list[str] = Field(default_factory=list)  # what the scenario shows ('traffic_cone (stationary)')
    call_id: str | None = None  # the model call that decided, when ``by`` is 'model'


CausalStatus = Literal["caused", "not_necessary", "not_sufficient", "confounded", "not_checked"]


class ReferenceRun(Model):
    """The reference robot (a careful driver, say) in one world of the but-for check."""

    removed: list[str] = Field(default_factory=list)  # entities left out of this world
    shown: bool  # it showed the behavior class, after the cause where the world has one
    happened: bool | None = None  # it showed the behavior class at all (for whatever reason)
    reacted_to: str | None = None  # the entity it reacted to, by its own account
    onset: float | None = None  # [s] when its reaction started
    cause_at: float | None = None  # [s] when the cause first showed (None: never, or no cause)
    summary: str = ""  # what it did, in words ("stopped at t = 6.1 s, 9.8 m before child1")


class EntityCheck(Model):
    """One entity that is not the cause: does it explain the behavior alone, is it needed?"""

    entity: str
    alone_shows: bool | None = None  # the cause removed, this entity kept: the behavior is shown
    without_it_shows: bool | None = None  # only this entity removed: the behavior is still shown


class Causal(Model):
    """Whether the cause *causes* the behavior, decided by simulation with a reference robot
    that reacts only to what it perceives (never the scripted one, which acts whatever the world
    does). ``caused``: with the cause the reference shows the behavior after the cause shows,
    and with the cause removed (the rest of the world and the solved parameters kept) it does
    not. ``not_sufficient``: the reference ignores the cause. ``not_necessary``: it shows the
    behavior without the cause too (``reason`` names what else explains it). ``confounded``:
    another entity explains the behavior on its own (``confounders`` names it).
    ``not_checked``: ``reason`` says why."""

    status: CausalStatus
    reason: str
    by: str = ""  # who reacted ("reference driver (IDM, MOBIL)")
    behavior: str = ""  # the behavior class checked ("stops", "changes lane")
    cause: list[str] = Field(default_factory=list)  # the entities taken as the cause
    cause_from: str = ""  # how they were found ("named by the cause's words", ...)
    with_cause: ReferenceRun | None = None
    without_cause: ReferenceRun | None = None
    others: list[EntityCheck] = Field(default_factory=list)
    confounders: list[str] = Field(default_factory=list)


class Verdict(Model):
    """``verified``: the FSM as grounded was accepted. ``verified_after_relaxation``: accepted
    only after over-strict stages were relaxed; ``relaxations`` says which and why.
    ``cause_not_shown``: the simulation ran, but a state in which the cause plays out was never
    reached (before the robot's reaction), so the scenario does not show its cause.
    ``ungroundable``: grounding could not honor what the causal graph decided (an entity's
    behavior, start location, speed or state) and says which; it never swaps it silently.
    ``unfaithful``: the FSM played out, but the scenario does not show the entities or states
    its cause's words name (``fidelity`` says what the text names and what the scenario shows)."""

    feasible: bool
    status: VerdictStatus
    reason: str
    stages: list[StageResult] = Field(default_factory=list)
    first_unmet_stage: int | None = None  # 1-based
    relaxations: list[str] = Field(default_factory=list)  # FSM stages relaxed during verification
    placement_relaxations: list[str] = Field(default_factory=list)  # what the solver relaxed
    fallbacks: list[str] = Field(default_factory=list)  # scenario parts rules wrote for the model
    conflicts: list[str] = Field(default_factory=list)
    fidelity: Fidelity | None = None  # what the cause names against what the scenario shows
    #: whether the cause causes the behavior (a reference robot with and without it); beside
    #: the status, never instead of it
    causal: Causal | None = None
    #: sentences of the model's narrative that claim what the simulation does not show, each
    #: marked as the model's claim with what the simulation shows (:mod:`regen.verify.claims`)
    claims: list[str] = Field(default_factory=list)

    @model_validator(mode="after")
    def _feasible_matches_status(self) -> Verdict:
        if self.feasible != (self.status in FEASIBLE_STATUSES):
            raise ValueError(f"feasible={self.feasible} contradicts status {self.status!r}")
        return self
