"""Feasibility breakdown per behavior and per scenario (the paper's appendix tables).

A scenario counts as feasible when its verdict says ``feasible: true`` (the FSM reached its
accepting stage). Scenarios without a verdict are listed as ``missing`` and are left out of the
success rate, so an unfinished run does not look like a failing one.
"""

from __future__ import annotations

from collections import Counter

from pydantic import BaseModel, Field

from regen.evaluation.runs import RunRecord


class ScenarioFeasibility(BaseModel):
    behavior: str
    scenario: str  # scenario id (folder name)
    causes: list[str] = Field(default_factory=list)
    feasible: bool | None
    status: str
    reason: str = ""
    first_unmet_stage: int | None = None
    run: str = ""  # run folder


class BehaviorFeasibility(BaseModel):
    behavior: str
    domain: str | None = None
    scenarios: int  # all scenario folders
    evaluated: int  # with a verdict
    feasible: int
    success_rate: float | None  # feasible / evaluated; None when nothing was evaluated
    statuses: dict[str, int] = Field(default_factory=dict)


class FeasibilityReport(BaseModel):
    behaviors: list[BehaviorFeasibility]
    scenarios: list[ScenarioFeasibility]
    total: BehaviorFeasibility  # over all behaviors


def _summarize(behavior: str, domain: str | None, rows: list[ScenarioFeasibility]) -> BehaviorFeasibility:
    evaluated = [r for r in rows if r.feasible is not None]
    feasible = sum(1 for r in evaluated if r.feasible)
    return BehaviorFeasibility(
        behavior=behavior, domain=domain, scenarios=len(rows), evaluated=len(evaluated),
        feasible=feasible, success_rate=(feasible / len(evaluated)) if evaluated else None,
        statuses=dict(sorted(Counter(r.status for r in rows).items())))


def feasibility_breakdown(runs: list[RunRecord]) -> FeasibilityReport:
    """Per-behavior and per-scenario feasibility over one or more run folders.

    Scenarios are grouped by their behavior text, so several runs of one behavior add up.
    """
    rows: list[ScenarioFeasibility] = []
    domains: dict[str, str | None] = {}
    for run in runs:
        for s in run.scenarios:
            domains.setdefault(s.behavior, s.domain or run.domain)
            rows.append(ScenarioFeasibility(
                behavior=s.behavior, scenario=s.id, causes=s.causes, feasible=s.feasible,
                status=s.status, reason=s.reason, first_unmet_stage=s.first_unmet_stage,
                run=run.path))
    by_behavior: dict[str, list[ScenarioFeasibility]] = {}
    for r in rows:
        by_behavior.setdefault(r.behavior, []).append(r)
    behaviors = [_summarize(b, domains.get(b), rs) for b, rs in by_behavior.items()]
    return FeasibilityReport(behaviors=behaviors, scenarios=rows,
                             total=_summarize("all behaviors", None, rows))
