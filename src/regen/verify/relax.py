"""Relaxing over-strict FSMs, the paper's main failure mode (two things asked of one instant).

When every condition of the first unmet stage held at some time, but never all at once, the
stage is split into consecutive stages ordered by when each condition first held on its own. The
verdict then says ``verified_after_relaxation`` and lists, per split, what was relaxed and why:
a relaxed scenario is never reported as plainly verified.

A state the model wrote for another actor than the robot, that is not a cause state and never
held after the previous stage, was the model's mistake about the scenario (a pedestrian "on the
sidewalk" while it crosses): it is dropped from its stage, with a note. Cause states and the
robot's own states are never dropped, and a rule-written FSM is never relaxed this way.
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


def drop_never_held(scenario: Scenario, verdict: Verdict) -> tuple[FSM, str] | None:
    """Drop from the first unmet stage of ``scenario``'s FSM the model's states of other actors
    (not cause states) that never held after the previous stage; None when there is none."""
    fsm = scenario.fsm
    k = verdict.first_unmet_stage
    if (k is None or verdict.status != "fsm_incomplete" or scenario.fsm_source == "rules"):
        return None
    robot = scenario.robot()  # the robot's own states are never dropped
    robots = {robot.name} if robot is not None else set()
    alone = verdict.stages[k - 1].satisfied_alone
    conds = fsm.stages[k - 1].conditions
    gone = [c for c in conds if c.actor not in robots and alone.get(f"{c.actor}: {c.state}") is None
            and not fsm.state(c.actor, c.state).cause]
    if not gone:
        return None
    kept = [c for c in conds if c not in gone]
    stages = fsm.stages[: k - 1] + ([Stage(conditions=kept)] if kept else []) + fsm.stages[k:]
    used = {(c.actor, c.state) for st in stages for c in st.conditions}
    states = [st for st in fsm.states if (st.actor, st.name) in used]
    what = "; ".join(f"{c.actor}: {c.state} ({', '.join(map(str, fsm.state(c.actor, c.state).all_of))})"
                     for c in gone)
    note = (f"stage {k}: dropped the model's state {what}, which never held after the previous stage "
            "(the model's mistake about the scenario; its cause states still had to hold)")
    return FSM(states=states, stages=stages), note


def verify_with_relaxation(scenario: Scenario, trace: Trace, *,
                           max_relaxations: int = MAX_RELAXATIONS) -> tuple[Verdict, Scenario]:
    """The FSM verdict; over-strict stages are relaxed up to a cap. Returns the verdict and the
    scenario whose FSM it judged (the relaxed one when a relaxation was needed)."""
    verdict = check_fsm(scenario, trace)
    notes: list[str] = []
    for _ in range(max_relaxations):
        if verdict.feasible:
            break
        relaxed = relax_fsm(scenario.fsm, verdict) or drop_never_held(scenario, verdict)
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
                          reason=f"{verdict.reason}, after relaxing {len(notes)} stage(s) of the FSM")
        verdict = verdict.model_copy(update=update)
    return verdict, scenario
