"""The desired ego action of a driving sample: one label of :data:`LABELS`, derived from the
ego's states in the FSM (the ego template's reaction states where the scenario names a
template, else the scenario's own ego states) and checked against the trace after the decision
moment. A label the trace contradicts is no label: the sample is left out with the reason.

The decision moment is the time the FSM stage holding the ego's first reaction state was
reached (``verdict.json``: ``stages[k].reached_at``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from regen.core.scenario import AbstractState, PredicateCall, Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.dataset.motion import LATERAL, SPEED_CHANGE, STILL, TURN, After, after

#: The fixed label set, with what each means (the dataset card lists it).
LABELS: dict[str, str] = {
    "keep_speed": "keep the current speed and lane",
    "accelerate": "speed up (e.g. drive off from standstill)",
    "slow_down": "brake to a lower speed without stopping",
    "stop": "brake to a standstill",
    "change_lane_left": "move into the lane on the left",
    "change_lane_right": "move into the lane on the right",
    "turn_left": "turn left at a junction",
    "turn_right": "turn right at a junction",
    "pull_over": "move to the right edge of the road and stop",
    "yield": "give way: stop or wait for another road user to pass",
}
STOPPING = frozenset({"braking", "stopped", "slower_than", "brake_lights_on"})
#: Ego predicates that show a reaction when the scenario names no template.
REACTION_PREDICATES = STOPPING | {"changing_lane", "turning", "accelerating"}
EGO = "ego"


class LeftOut(Exception):
    """A scenario that gives no sample; the message is the reason (counted in the card)."""

    def __init__(self, reason: str, detail: str = ""):
        super().__init__(reason)
        self.reason, self.detail = reason, detail


@dataclass(frozen=True)
class Label:
    """A sample's label: the action, the decision moment, and what the trace showed."""

    action: str
    t: float  # [s] decision moment
    stage: int  # 1-based FSM stage holding the ego's first reaction state
    evidence: str  # what the trace shows after t, in words


def ego_name(scenario: Scenario) -> str:
    """The robot's entity name (``ego`` in driving)."""
    return next((e.name for e in scenario.entities if e.kind == "robot"), EGO)


def _reaction(scenario: Scenario):
    """The domain's (is_reaction, (first state, reaction states)) of the scenario's robot
    template (:meth:`regen.contract.DatasetViews.reaction`), or None (no template known)."""
    from regen import domains

    views = domains.make(scenario.domain).dataset_views()
    return None if views is None else views.reaction(scenario)


def _calls(states: Iterable[AbstractState | tuple[str, list[PredicateCall]]]) -> list[PredicateCall]:
    out: list[PredicateCall] = []
    for s in states:
        out += [c for c in (s.all_of if isinstance(s, AbstractState) else s[1]) if not c.negate]
    return out


def decision(scenario: Scenario, verdict: Verdict) -> tuple[int, float]:
    """(1-based stage, time [s]) of the FSM stage holding the ego's first reaction state;
    LeftOut when there is none or it was never reached."""
    ego = ego_name(scenario)
    template = _reaction(scenario)
    states = {(s.actor, s.name): s for s in scenario.fsm.states}
    for k, stage in enumerate(scenario.fsm.stages, start=1):
        for c in stage.conditions:
            s = states.get((c.actor, c.state))
            if c.actor != ego or s is None:
                continue
            react = (template[0](s) if template is not None
                     else any(p.name in REACTION_PREDICATES for p in _calls([s])))
            if not react:
                continue
            reached = next((r.reached_at for r in verdict.stages if r.index == k), None)
            if reached is None:
                raise LeftOut("no decision moment", f"stage {k} (the ego's reaction) was never reached")
            return k, float(reached)
    raise LeftOut("no decision moment", "no FSM stage holds a reaction state of the ego")


def _lane(calls: list[PredicateCall]) -> int | None:
    lanes = [int(float(c.params["lane"])) for c in calls if c.name == "in_lane" and "lane" in c.params]
    return lanes[-1] if lanes else None


def intended(scenario: Scenario, stage: int, motion: After) -> str:
    """The action the ego's reaction states name: the template's own (initial state, reaction
    states) where the scenario names one, else the scenario's ego states from ``stage`` on.
    A direction the states do not give (which way a turn goes) is read from ``motion``."""
    template = _reaction(scenario)
    if template is not None:
        first, reaction = template[1]
        start, react = _calls([first]), _calls(reaction)
    else:
        ego = ego_name(scenario)
        states = {(s.actor, s.name): s for s in scenario.fsm.states}
        own = [[states[(c.actor, c.state)] for c in st.conditions
                if c.actor == ego and (c.actor, c.state) in states] for st in scenario.fsm.stages]
        start = _calls([s for st in own[: stage - 1] for s in st])
        react = _calls([s for st in own[stage - 1:] for s in st])
    names = {c.name for c in react}
    before, now = _lane(start), _lane(react)
    if "stopped" in names:
        return "stop"
    if "changing_lane" in names or (before is not None and now is not None and now != before):
        if before is not None and now is not None and now != before:
            # lane 0 is the innermost lane of the ego's direction, beside the centre line: a lower
            # index is further left (right-hand traffic, regen.driving.world.egos.base.Frame)
            return "change_lane_left" if now < before else "change_lane_right"
        return "change_lane_left" if motion.left > 0 else "change_lane_right"
    if "turning" in names:
        return "turn_left" if motion.turned > 0 else "turn_right"
    if names & STOPPING:
        return "slow_down"
    if names & {"accelerating", "moving", "steady"}:
        return "accelerate"
    raise LeftOut("no action for the ego's states",
                  f"the ego's reaction states ({', '.join(sorted(names)) or 'none'}) name no action of the label set")


def describe(m: After) -> str:
    """What the trace shows after the decision moment, in words."""
    parts = [f"speed {m.speed:.1f} m/s at t = {m.t:.1f} s"]
    parts.append(f"stops at t = {m.stops_at:.1f} s" if m.stops_at is not None and m.speed > STILL
                 else f"slowest {m.slowest:.1f} m/s, fastest {m.fastest:.1f} m/s until t = {m.t_end:.1f} s")
    if abs(m.left) >= LATERAL:
        parts.append(f"{abs(m.left):.1f} m to the {'left' if m.left > 0 else 'right'}")
    if abs(m.turned) >= TURN:
        parts.append(f"turns {abs(math.degrees(m.turned)):.0f} deg {'left' if m.turned > 0 else 'right'}")
    return ", ".join(parts)


def contradiction(action: str, m: After) -> str | None:
    """Why the trace after the decision moment contradicts ``action``; None when it agrees."""
    v0 = max(m.speed, m.before)
    if action in ("stop", "yield", "pull_over") and m.slowest > STILL:
        return f"a '{action}' label, but the ego never stops after t = {m.t:.1f} s (slowest {m.slowest:.1f} m/s)"
    if action == "pull_over" and m.left > -LATERAL:
        return f"a 'pull_over' label, but the ego does not move right ({m.left:+.1f} m)"
    if action == "slow_down":
        if m.slowest > v0 - SPEED_CHANGE:
            return f"a 'slow_down' label, but the ego keeps {m.slowest:.1f} of {v0:.1f} m/s"
        if m.stops_at is not None and m.speed > STILL:
            return f"a 'slow_down' label, but the ego stops at t = {m.stops_at:.1f} s"
    if action == "accelerate" and m.fastest < m.speed + SPEED_CHANGE:
        return f"an 'accelerate' label, but the ego reaches only {m.fastest:.1f} m/s from {m.speed:.1f} m/s"
    if action.startswith("change_lane_"):
        side = 1 if action.endswith("left") else -1
        if side * m.left < LATERAL:
            return (f"a '{action}' label, but the ego moves {abs(m.left):.1f} m to the "
                    f"{'left' if m.left > 0 else 'right'}")
    if action.startswith("turn_"):
        side = 1 if action.endswith("left") else -1
        if side * m.turned < TURN:
            return f"a '{action}' label, but the ego's heading changes {math.degrees(m.turned):+.0f} deg"
    if action == "keep_speed" and (m.slowest < v0 - SPEED_CHANGE or m.fastest > v0 + SPEED_CHANGE):
        return f"a 'keep_speed' label, but the ego's speed ranges {m.slowest:.1f}-{m.fastest:.1f} m/s"
    return None


def classify(m: After) -> str:
    """The action a trace shows after a moment, from the trace alone (counterfactual answers)."""
    if abs(m.turned) >= TURN:
        return "turn_left" if m.turned > 0 else "turn_right"
    if abs(m.left) >= LATERAL and m.slowest > STILL:
        return "change_lane_left" if m.left > 0 else "change_lane_right"
    if m.speed > STILL and m.stops_at is not None:
        return "pull_over" if m.left <= -LATERAL else "stop"
    v0 = max(m.speed, m.before)
    if m.slowest < v0 - SPEED_CHANGE:
        return "slow_down"
    if m.fastest > m.speed + SPEED_CHANGE:
        return "accelerate"
    return "keep_speed"


def label(scenario: Scenario, trace: Trace, verdict: Verdict) -> Label:
    """The sample's label; LeftOut with the reason when there is none or the trace contradicts it."""
    stage, t = decision(scenario, verdict)
    ego = ego_name(scenario)
    if ego not in trace.actors:
        raise LeftOut("no ego in the trace", f"the trace holds no actor {ego!r}")
    m = after(trace, ego, t)
    action = intended(scenario, stage, m)
    why = contradiction(action, m)
    if why is not None:
        raise LeftOut("trace contradicts the label", why)
    return Label(action=action, t=m.t, stage=stage, evidence=describe(m))


__all__ = ["EGO", "LABELS", "Label", "LeftOut", "classify", "contradiction", "decision", "describe",
           "ego_name", "intended", "label"]
