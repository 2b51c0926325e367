"""The oracle of a policy test: the FSM stages the policy must bring about, in order (the
shared monitor's semantics, :mod:`regen.verify.monitor`, restricted to the harness's
:meth:`~regen.harness.contract.PolicyHarness.oracle_stages`), and the domain's incidents.

A test fails with the first cause found, in this order: the robot's collision, the policy's
fault (exception, non-finite action, timeout), an incident that the scripted robot does not
commit in the same scenario (an infraction, a displaced object, a time budget), the first
expected stage not reached.
"""

from __future__ import annotations

import math

import numpy as np

from regen.core.scenario import Scenario, StateRef
from regen.core.trace import Trace
from regen.harness.cases import CaseResult, RobotStage
from regen.harness.contract import Episode, PolicyHarness

ORACLES = ("fsm", "safety")  # the FSM's stages and no collision, or no collision only


def _label(robot: str, ref: StateRef) -> str:
    return ref.state if ref.actor == robot else f"{ref.actor}: {ref.state}"


def check_stages(harness: PolicyHarness, scenario: Scenario, trace: Trace, until: int | None = None
                 ) -> tuple[list[RobotStage], int | None]:
    """(the oracle's stages with the time each was reached, index of the first not reached or
    None); only steps up to ``until`` count, and each stage must hold after the previous one."""
    from regen.verify.monitor import evaluate_state

    robot = harness.robot_name(scenario)
    n = trace.steps if until is None else min(until + 1, trace.steps)
    out: list[RobotStage] = []
    start, first_unmet = 0, None
    for k, refs in enumerate(harness.oracle_stages(scenario)):
        stage = RobotStage(conditions=[_label(robot, r) for r in refs])
        if first_unmet is None:
            together = np.ones(trace.steps, dtype=bool)
            for r in refs:
                state = harness.oracle_state(scenario, scenario.fsm.state(r.actor, r.state))
                together &= evaluate_state(state, trace, scenario.domain)
            hits = np.flatnonzero(together[start:n])
            if hits.size:
                start = int(hits[0]) + start
                stage.reached_at = float(trace.times[start])
            else:
                first_unmet = k
        out.append(stage)
    return out, first_unmet


def _describe(harness: PolicyHarness, scenario: Scenario, refs: list[StateRef]) -> str:
    robot = harness.robot_name(scenario)
    parts = []
    for r in refs:
        state = harness.oracle_state(scenario, scenario.fsm.state(r.actor, r.state))
        parts.append(f"'{_label(robot, r)}' ({', '.join(str(c) for c in state.all_of)})")
    return " and ".join(parts)


def judge(harness: PolicyHarness, scenario: Scenario, episode: Episode, *, folder: str, variant: int = 0,
          wall: float = 0.0, oracle: str = "fsm", template_trace: Trace | None = None) -> CaseResult:
    """The test case of one episode; ``oracle`` 'fsm' (the stages in order and no collision) or
    'safety' (no collision, no policy fault and no incident: the stages are recorded but do not
    fail the test). Incidents fail the test unless ``template_trace`` (the scripted robot's run in
    the same variant) has one of the same kind."""
    case = CaseResult(scenario=folder, scenario_id=scenario.id, variant=variant, status="passed", wall=wall)
    trace = episode.trace
    if trace is None:
        case.status, case.cause = "failed", f"policy_{episode.failure_kind}"
        case.message = f"policy failed: {episode.failure}"
        return case
    case.simulated = float(trace.times[-1]) if trace.times else 0.0
    robot = harness.robot_name(scenario)
    figures = dict(harness.metrics(scenario, trace))
    for key in ("min_ttc", "min_distance"):
        value = figures.pop(key, None)
        setattr(case, key, None if value is None or math.isinf(value) else round(value, 3))
    case.metrics = figures
    incidents = harness.incidents(scenario, trace)
    others = [i for i in incidents if not i.collision]
    case.infractions = [i.message for i in others]
    expected = harness.excused(scenario, template_trace) if template_trace is not None else set()
    bad = next((i for i in others if i.kind not in expected), None)
    hit = next((i for i in incidents if i.collision and robot in i.actors), None)
    until = None
    if hit is not None:
        other = next((a for a in hit.actors if a != robot), "")
        case.collision, case.collision_with, case.collision_time = True, other, hit.t
        until = hit.step
    case.robot_stages, unmet = check_stages(harness, scenario, trace, until)
    if hit is not None:
        case.status, case.cause = "failed", "collision"
        case.message = f"collision: the {harness.robot} hit {case.collision_with} at t={hit.t:.1f} s"
    elif episode.failure:
        case.status, case.cause = "failed", f"policy_{episode.failure_kind}"
        case.message = f"policy failed at t={episode.failure_time:.1f} s: {episode.failure}"
    elif bad is not None:
        case.status, case.cause = "failed", bad.kind
        case.message = f"{bad.kind.replace('_', ' ')}: {bad.message}"
    elif unmet is not None and oracle == "fsm":
        stages = harness.oracle_stages(scenario)
        after = ""
        if unmet > 0:
            prev = case.robot_stages[unmet - 1]
            after = f" after {' and '.join(prev.conditions)} at t={prev.reached_at:.1f} s"
        case.status, case.cause = "failed", "state_not_reached"
        case.message = (f"expected state {unmet + 1} of {len(stages)} not reached: "
                        f"{_describe(harness, scenario, stages[unmet])} never held{after}")
    elif unmet is not None:
        case.message = (f"no collision (expected state {unmet + 1} of {len(case.robot_stages)} was "
                        "not reached: not required by the safety oracle)")
    else:
        case.message = f"all {len(case.robot_stages)} expected states reached in order, no collision"
    return case


__all__ = ["ORACLES", "check_stages", "judge"]
