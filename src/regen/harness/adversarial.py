"""Corner cases: variants of a run's scenarios that make the policy under test fail.

``regen test RUN --policy SPEC --adversarial [--variants N]`` searches each verified scenario's
CP-SAT feasible set with a seeded budget of N candidates (:data:`DEFAULT_BUDGET` when not given):
the scenario as grounded, then points pushed to the ends of their feasible ranges (the
harness's ``sample_variants(..., extremes=True)``). A candidate counts only when the scripted
robot, in the same variant, verifies and collides with nothing, so no failure it finds is
inevitable; the others are skipped with the reason. The failing candidates are the corner cases,
reported with their parameters (``tests.json`` marks every case ``adversarial`` and carries its
scripted-robot check).
"""

from __future__ import annotations

from collections.abc import Mapping

from regen.harness.cases import CaseResult, SuiteReport

DEFAULT_BUDGET = 16  # candidates per scenario when --variants is not given


def failing(report: SuiteReport) -> list[CaseResult]:
    """The candidates that made the policy fail while the scripted robot verified and collided
    with nothing in the same variant."""
    return [c for c in report.cases if c.adversarial and c.status == "failed" and c.template is not None
            and c.template.verified and not c.template.collision]


def _parameters(c: CaseResult, units: Mapping[str, str]) -> str:
    return "; ".join(f"{actor} " + ", ".join(f"{k}={v:g} {units.get(k, '')}".rstrip() for k, v in p.items())
                     for actor, p in c.parameters.items() if p) or "no parameters"


def summary_lines(report: SuiteReport, units: Mapping[str, str] | None = None) -> list[str]:
    """Terminal lines of an adversarial search: a count, then one line per failing variant
    with its cause and parameters (``units``: the harness's parameter units); empty when the
    report is not adversarial."""
    if not report.adversarial:
        return []
    found = failing(report)
    tried = [c for c in report.cases if c.adversarial and c.template is not None]
    invalid = sum(c.status == "skipped" for c in tried)
    head = (f"adversarial: {len(found)} failing variant{'s' if len(found) != 1 else ''} of {len(tried)} "
            f"candidates ({invalid} skipped: the scripted {report.robot} did not verify or collided)")
    if not found:
        return [head, "adversarial: no failing variant found; the policy passed every valid candidate"]
    lines = [head]
    for c in found:
        what = f"collision with {c.collision_with}" if c.collision else c.cause
        lines.append(f"  {c.scenario}[variant {c.variant}]: {what}; parameters: {_parameters(c, units or {})}; "
                     f"scripted {report.robot}: {c.template.status}, no collision")
    return lines


__all__ = ["DEFAULT_BUDGET", "failing", "summary_lines"]
