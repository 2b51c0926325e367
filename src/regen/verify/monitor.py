"""The FSM monitor: did the stages of a scenario play out, in order, in the trace?

Semantics: stage k is reached at the first step, no earlier than the step where stage k-1 was
reached, at which every condition of stage k holds at once. The FSM is accepted when its last
stage is reached. Where a stage is never reached, the verdict names it and says, per condition,
whether and when it held on its own; that is what grounding's relaxation looks at.
"""

from __future__ import annotations

import numpy as np

from regen.core.scenario import FSM, AbstractState, Scenario
from regen.core.trace import Trace
from regen.core.verdict import StageResult, Verdict
from regen.errors import ConfigError
from regen.verify.predicates import get_predicate


def validate_fsm(fsm: FSM, actors: set[str], domain: str) -> list[str]:
    """Problems of an FSM before anything runs: unknown predicates, actors, wrong arity."""
    problems: list[str] = []
    if not fsm.stages:
        problems.append("the FSM has no stages")
    for s in fsm.states:
        if s.actor not in actors:
            problems.append(f"state {s.name!r} belongs to unknown actor {s.actor!r}")
        for call in s.all_of:
            try:
                spec = get_predicate(call.name, domain)
            except ConfigError as exc:
                problems.append(f"state {s.name!r}: {exc}")
                continue
            if len(call.args) != spec.arity:
                problems.append(f"state {s.name!r}: {spec.name} takes {spec.arity} actor(s), "
                                f"got {call.args}")
            unknown = [a for a in call.args if a not in actors]
            if unknown:
                problems.append(f"state {s.name!r}: {call} names unknown actor(s) {unknown}")
            bad = [k for k in call.params if k not in spec.params]
            if bad:
                problems.append(f"state {s.name!r}: {spec.name} has no parameter(s) {bad}; "
                                f"it takes {sorted(spec.params)}")
    return problems


def evaluate_state(state: AbstractState, trace: Trace, domain: str) -> np.ndarray:
    """Boolean per step: does the abstract state hold?"""
    out = np.ones(trace.steps, dtype=bool)
    for call in state.all_of:
        spec = get_predicate(call.name, domain)
        params = {**spec.params, **call.params}
        val = np.asarray(spec.fn(trace, list(call.args), params), dtype=bool)
        out &= ~val if call.negate else val
    return out


def _first(mask: np.ndarray, start: int) -> int | None:
    idx = np.flatnonzero(mask[start:])
    return int(idx[0]) + start if idx.size else None


def _notes(scenario: Scenario) -> dict[str, list[str]]:
    """What grounding recorded that the verdict must carry (never passed silently)."""
    return {"placement_relaxations": list(scenario.solver.relaxations),
            "fallbacks": list(scenario.fallbacks)}


def check_fsm(scenario: Scenario, trace: Trace) -> Verdict:
    """Run the FSM of ``scenario`` over ``trace`` and return the verdict."""
    fsm = scenario.fsm
    problems = validate_fsm(fsm, {e.name for e in scenario.entities}, scenario.domain)
    missing = sorted({e.name for e in scenario.entities} - set(trace.actors))
    if missing:
        problems.append(f"the trace has no record of actor(s) {missing}")
    if problems:
        return Verdict(feasible=False, status="invalid_scenario", reason="; ".join(problems),
                       **_notes(scenario))
    masks = {(s.actor, s.name): evaluate_state(s, trace, scenario.domain) for s in fsm.states}
    results: list[StageResult] = []
    start = 0
    first_unmet: int | None = None
    for k, stage in enumerate(fsm.stages, start=1):
        labels = [f"{c.actor}: {c.state}" for c in stage.conditions]
        alone = {lab: _first(masks[(c.actor, c.state)], start)
                 for lab, c in zip(labels, stage.conditions, strict=True)}
        res = StageResult(index=k, conditions=labels,
                          satisfied_alone={lab: (trace.times[i] if i is not None else None)
                                           for lab, i in alone.items()})
        if first_unmet is None:
            together = np.ones(trace.steps, dtype=bool)
            for c in stage.conditions:
                together &= masks[(c.actor, c.state)]
            hit = _first(together, start)
            if hit is None:
                first_unmet = k
            else:
                res.reached_at = trace.times[hit]
                start = hit
        results.append(res)
    if first_unmet is None:
        return Verdict(feasible=True, status="verified",
                       reason=f"all {len(results)} stages reached in order; accepted at "
                              f"t={results[-1].reached_at:.1f} s",
                       stages=results, **_notes(scenario))
    stage = results[first_unmet - 1]
    never = [lab for lab, t in stage.satisfied_alone.items() if t is None]
    if never:
        why = "never held after the previous stage: " + ", ".join(never)
    else:
        why = "each condition held at some time, but never all at once"
    causes = [f"{c.actor}: {c.state}" for c in fsm.stages[first_unmet - 1].conditions
              if fsm.state(c.actor, c.state).cause]
    if causes:  # the cause itself did not play out: the scenario does not show what it claims
        return Verdict(feasible=False, status="cause_not_shown",
                       reason=f"the cause did not play out: stage {first_unmet} "
                              f"({'; '.join(stage.conditions)}) was not reached: {why}",
                       stages=results, first_unmet_stage=first_unmet, **_notes(scenario))
    return Verdict(feasible=False, status="fsm_incomplete",
                   reason=f"stage {first_unmet} ({'; '.join(stage.conditions)}) was not reached: {why}",
                   stages=results, first_unmet_stage=first_unmet, **_notes(scenario))
