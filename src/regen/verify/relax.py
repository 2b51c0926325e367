"""Relaxing over-strict FSMs, the paper's main failure mode (two things asked of one instant).

When every condition of the first unmet stage held at some time, but never all at once, the
stage is split into consecutive stages ordered by when each condition first held on its own. The
verdict then says ``verified_after_relaxation`` and lists, per split, what was relaxed and why:
a relaxed scenario is never reported as plainly verified.
"""

from __future__ import annotations

import logging

from regen.core.scenario import FSM, Scenario, Stage
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.verify.monitor import check_fsm

log = logging.getLogger(__name__)

MAX_RELAXATIONS = 3  # stage splits tried per scenario


def relax_fsm(fsm: FSM, verdict: Verdict) -> tuple[FSM, str] | None:
    """Split the first unmet stage into consecutive stages, ordered by when each condition first
    held on its own, when every condition held at some time but never all at once."""
    k = verdict.first_unmet_stage
    if k is None or verdict.status not in ("fsm_incomplete", "cause_not_shown"):
        return None
    alone = verdict.stages[k - 1].satisfied_alone
    if len(alone) < 2 or any(t is None for t in alone.values()):
        return None
    conds = fsm.stages[k - 1].conditions
    labels = [f"{c.actor}: {c.state}" for c in conds]
    order = sorted(range(len(conds)), key=lambda i: (alone[labels[i]], i))
    new = [Stage(conditions=[conds[i]]) for i in order]
    stages = fsm.stages[: k - 1] + new + fsm.stages[k:]
    note = (f"stage {k} ({'; '.join(labels)}) required its conditions at the same instant, which "
            f"never happened; relaxed into {len(new)} consecutive stages: "
            + " -> ".join(labels[i] for i in order))
    return FSM(states=fsm.states, stages=stages), note


def verify_with_relaxation(scenario: Scenario, trace: Trace, *,
                           max_relaxations: int = MAX_RELAXATIONS) -> tuple[Verdict, Scenario]:
    """The FSM verdict; over-strict stages are relaxed up to a cap. Returns the verdict and the
    scenario whose FSM it judged (the relaxed one when a relaxation was needed)."""
    verdict = check_fsm(scenario, trace)
    notes: list[str] = []
    for _ in range(max_relaxations):
        if verdict.feasible:
            break
        relaxed = relax_fsm(scenario.fsm, verdict)
        if relaxed is None:
            break
        fsm, note = relaxed
        log.info("relaxing the FSM of %s: %s", scenario.id, note)
        notes.append(note)
        scenario = scenario.model_copy(update={"fsm": fsm})
        verdict = check_fsm(scenario, trace)
    if notes:
        update: dict = {"relaxations": notes}
        if verdict.feasible:
            update.update(status="verified_after_relaxation",
                          reason=f"{verdict.reason}, after relaxing {len(notes)} over-strict stage(s)")
        verdict = verdict.model_copy(update=update)
    return verdict, scenario
