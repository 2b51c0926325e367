"""The question-answer layers of a sample, every answer computed from the trace, the causal
graph, the verdict's but-for check or a simulated what-if, never by a model:

- ``perception``: which entities are around the ego at the decision moment, where (ahead,
  behind, left, right of the ego's heading, with the centre distance in metres) and in what
  state (moving or stationary, the states the trace records, such as a light's colour);
- ``prediction``: what each cause actor does next, from its trace over :data:`HORIZON` seconds
  after the decision moment (crosses the road, drives on, stops, stays stopped, changes state);
- ``planning``: the desired action (the sample's label) and why: the root cause of the causal
  graph and the cause actors where the perception layer sees them;
- ``counterfactual``: what the ego does with the cause removed (the reference driver's run
  without the cause, ``verdict.causal.without_cause``), and in each simulated what-if of the
  scenario (its ego trace after the same moment, with the what-if's verdict).

Every QA also holds multiple-choice ``options`` and the ``key`` among them, computed from the
same numbers as its answer, so that a model's answer is scored by exact match
(``regen probe``): where is an entity -> :data:`DIRECTIONS`; what does a cause actor do ->
:data:`MOTIONS`; planning and counterfactual -> the action labels. A question with no single
option (which entities are around the ego, an unknown counterfactual) has ``key`` None and is
not scored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.dataset.labels import LABELS, Label, ego_name
from regen.dataset.motion import LATERAL, STILL, after, headings, relative, speeds, step_at

LAYERS = ("perception", "prediction", "planning", "counterfactual")
HORIZON = 3.0  # [s] how far after the decision moment a prediction looks
AHEAD = math.radians(30.0)  # within this angle of the ego's heading an entity is 'ahead' (or 'behind')
#: states of what the ego's own sensors perceive, not of the world: left out of answers
SENSOR_STATES = ("perceived_", "gnss", "view_lost")
#: states of where an actor is, said in words by :func:`_place`
PLACE_STATES = ("lane", "on_road", "on_sidewalk", "in_junction")
#: options of 'where is X': the side of the ego (ahead / behind within :data:`AHEAD`)
DIRECTIONS = ("ahead", "behind", "left", "right")
#: options of 'what does X do next': the main motion class of :func:`predict`'s answer
CROSS_LEFT, CROSS_RIGHT = "crosses the ego's path towards its left", "crosses the ego's path towards its right"
MOVES_ON, COMES, STAYS = "moves on in the ego's direction", "comes towards the ego", "stays in place"
MOTIONS = (CROSS_LEFT, CROSS_RIGHT, MOVES_ON, COMES, STAYS)
ACTIONS = tuple(LABELS)  # options of planning and counterfactual questions


@dataclass(frozen=True)
class QA:
    layer: str
    question: str
    answer: str
    source: str  # what the answer is computed from
    options: tuple[str, ...] = ()  # the multiple-choice options (empty: not a choice)
    key: str | None = None  # the correct option; None: not scored


def visible_states(trace: Trace, name: str, i: int) -> dict[str, str]:
    """The recorded states of ``name`` at step ``i`` (sensor internals left out), as text."""
    out = {}
    for key, seq in sorted(trace.actors[name].states.items()):
        if key.startswith(SENSOR_STATES) or seq[i] is None:
            continue
        out[key] = str(seq[i]).lower() if isinstance(seq[i], bool) else str(seq[i])
    return out


def where(trace: Trace, ego: str, name: str, i: int) -> tuple[str, float]:
    """(ahead | behind | left | right, centre distance [m]) of ``name`` from the ego at step ``i``."""
    e, a = trace.actors[ego], trace.actors[name]
    along, left = relative(e.x[i], e.y[i], headings(e)[i], a.x[i], a.y[i])
    angle = math.atan2(left, along)
    side = ("ahead" if abs(angle) <= AHEAD else "behind" if abs(angle) >= math.pi - AHEAD
            else "left" if left > 0 else "right")
    return side, math.hypot(along, left)


def _place(states: dict[str, str]) -> str:
    if states.get("in_junction") == "true":
        return "in the junction"
    if states.get("on_road") == "true":
        return "on the road"
    if states.get("on_sidewalk") == "true":
        return "on the sidewalk"
    return ""


def state_text(trace: Trace, name: str, i: int) -> str:
    """'moving at 1.0 m/s, on the road, light_state green': motion, place and other states."""
    v = speeds(trace, trace.actors[name])[i]
    states = visible_states(trace, name, i)
    parts = ["stationary" if v <= STILL else f"moving at {v:.1f} m/s", _place(states)]
    parts += [f"{k} {val}" for k, val in states.items() if k not in PLACE_STATES]
    return ", ".join(p for p in parts if p)


def position_text(trace: Trace, ego: str, name: str, i: int) -> str:
    side, dist = where(trace, ego, name, i)
    return f"{side}, {dist:.0f} m"


def others(scenario: Scenario, trace: Trace) -> list[str]:
    ego = ego_name(scenario)
    return sorted(n for n in trace.actors if n != ego)


def cause_actors(scenario: Scenario, trace: Trace, verdict: Verdict) -> list[str]:
    """The entities the but-for check took as the cause, else the actors of the FSM's cause states."""
    named = list(verdict.causal.cause) if verdict.causal is not None else []
    if not named:
        named = sorted({s.actor for s in scenario.fsm.states if s.cause})
    return [n for n in named if n in trace.actors and n != ego_name(scenario)]


def perception(scenario: Scenario, trace: Trace, lab: Label) -> list[QA]:
    ego, i = ego_name(scenario), step_at(trace, lab.t)
    names = sorted(others(scenario, trace), key=lambda n: (round(where(trace, ego, n, i)[1], 3), n))
    assets = {n: trace.actors[n].asset for n in names}
    # the overview has no single option: not scored
    out = [QA("perception", f"Which road users and objects are around the ego at t = {lab.t:.1f} s?",
              "; ".join(f"{n} ({assets[n]}): {position_text(trace, ego, n, i)}" for n in names) or "none",
              "trace")]
    for n in names:
        out.append(QA("perception", f"Where is {n} ({assets[n]}) relative to the ego at t = {lab.t:.1f} s, "
                      "and in what state?", f"{position_text(trace, ego, n, i)}; {state_text(trace, n, i)}",
                      "trace", DIRECTIONS, where(trace, ego, n, i)[0]))
    return out


def _changes(trace: Trace, name: str, i: int, end: int) -> list[str]:
    out = []
    for key, seq in sorted(trace.actors[name].states.items()):
        if key.startswith(SENSOR_STATES) or key in PLACE_STATES:
            continue
        changed = [k for k in range(i + 1, end + 1) if seq[k] != seq[k - 1]]
        out += [f"{key} changes from {seq[k - 1]} to {seq[k]} at t = {trace.times[k]:.1f} s" for k in changed]
        if not changed and seq[i] is not None:
            out.append(f"{key} stays {seq[i]}")
    return out


def predict(trace: Trace, ego: str, name: str, t: float, horizon: float = HORIZON) -> str:
    """What ``name`` does in the ``horizon`` seconds after ``t`` [s], from its trace, in words
    relative to the ego's heading at ``t``."""
    return _predict(trace, ego, name, t, horizon)[0]


def _predict(trace: Trace, ego: str, name: str, t: float, horizon: float) -> tuple[str, str | None]:
    """(the answer, the option of :data:`MOTIONS` it leads with); the option is None for an
    actor that moves but ends where it started (no option fits)."""
    e, a = trace.actors[ego], trace.actors[name]
    i = step_at(trace, t)
    end = step_at(trace, trace.times[i] + horizon)
    m = after(trace, name, t, horizon)
    h = headings(e)[i]
    d_along = relative(0.0, 0.0, h, a.x[end] - a.x[i], a.y[end] - a.y[i])[0]
    d_left = relative(0.0, 0.0, h, a.x[end] - a.x[i], a.y[end] - a.y[i])[1]
    span = f"until t = {trace.times[end]:.1f} s"
    key: str | None = None
    if m.fastest <= STILL:
        parts = ["stays stopped" if trace.actors[name].kind != "object" else "stays in place"]
        key = STAYS
    else:
        parts = []
        if abs(d_left) >= LATERAL and abs(d_left) >= abs(d_along):
            parts.append(f"crosses the ego's path towards the ego's {'left' if d_left > 0 else 'right'} "
                         f"({abs(d_left):.1f} m)")
            key = CROSS_LEFT if d_left > 0 else CROSS_RIGHT
        elif d_along > 0:
            parts.append(f"moves on in the ego's direction ({d_along:.1f} m)")
            key = MOVES_ON
        elif d_along < 0:
            parts.append(f"comes towards the ego ({-d_along:.1f} m)")
            key = COMES
        if m.speed <= STILL:
            parts.insert(0, "starts moving")
        elif m.stops_at is not None and m.stops_at > m.t:
            parts.append(f"stops at t = {m.stops_at:.1f} s")
        place_now = _place(visible_states(trace, name, i))
        place_then = _place(visible_states(trace, name, end))
        if place_then != place_now and place_then:
            parts.append(f"ends {place_then}")
    parts += _changes(trace, name, i, end)
    return "; ".join(parts) + f" ({span})", key


def prediction(scenario: Scenario, trace: Trace, verdict: Verdict, lab: Label) -> list[QA]:
    ego = ego_name(scenario)
    out = []
    for n in cause_actors(scenario, trace, verdict):
        answer, key = _predict(trace, ego, n, lab.t, HORIZON)
        out.append(QA("prediction", f"What does {n} ({trace.actors[n].asset}) do in the next {HORIZON:.0f} s?",
                      answer, "trace", MOTIONS, key))
    return out


def planning(scenario: Scenario, trace: Trace, verdict: Verdict, lab: Label) -> list[QA]:
    ego, i = ego_name(scenario), step_at(trace, lab.t)
    causes = cause_actors(scenario, trace, verdict)
    seen = "; ".join(f"{n} {position_text(trace, ego, n, i)}" for n in causes)
    root = scenario.causal_graph[0] if scenario.causal_graph else "the scenario's cause"
    answer = f"{lab.action} ({LABELS[lab.action]}), because {root.rstrip('.')}" + (f" ({seen})" if seen else "")
    return [QA("planning", "What should the ego do now, and why?", answer, "label, graph, trace", ACTIONS,
               lab.action)]


def _without(verdict: Verdict) -> QA | None:
    c = verdict.causal
    if c is None or c.without_cause is None:
        return None
    run = c.without_cause
    gone = ", ".join(run.removed or c.cause) or "the cause"
    if run.happened:  # a 'caused' verdict never has this; kept truthful for other callers
        action = "the same"  # no label of its own: not scored
    else:
        action = "keep_speed"  # the behavior class is not shown: no stop, slowing, lane change or drive-off
    answer = (f"{action}: with {gone} removed, the {c.by or 'reference robot'} "
              f"{run.summary or ('shows' if run.shown else 'does not show') + ' ' + c.behavior} (simulated)")
    return QA("counterfactual", f"What would the ego do if {gone} were not there?", answer,
              "verdict.causal.without_cause", ACTIONS, action if action in LABELS else None)


def _reacts(run: Any, lab: Label) -> str:
    """The action of the reference robot's run in a world: the sample's own action where it shows
    the behavior, else keep_speed (no stop, slowing, lane change or drive-off)."""
    return lab.action if run.happened else "keep_speed"


def counterfactual(verdict: Verdict, lab: Label, whatifs: list[dict[str, Any]]) -> list[QA]:
    """The cause removed (the verdict's but-for run), then each what-if: ``whatifs`` holds
    dicts with 'record' (regen.whatif.WhatIf) and 'causal' (the counterfactual verdict's causal
    part). What the ego does in a what-if is what the reference driver did in the edited world
    (its ``with_cause`` run), never what the scripted ego did: the scripted ego replays its
    reaction whatever the world does (a stop at a green light is not an answer)."""
    out = [q for q in [_without(verdict)] if q is not None]
    for w in whatifs:
        rec, causal = w["record"], w.get("causal")
        edits = "; ".join(e.describe() for e in rec.edits)
        question = f"What if {rec.question.rstrip('?')}?" if rec.question else f"What if we {edits}?"
        run = causal.with_cause if causal is not None and causal.status != "not_checked" else None
        if run is None:
            action = "unknown (the edited world's cause was not checked with the reference driver)"
            how = f"causal {causal.status if causal is not None else 'not checked'}"
        else:
            action = _reacts(run, lab)
            how = f"the {causal.by or 'reference robot'} {run.summary or c_shown(run, causal.behavior)}"
        still = "still explained" if rec.explained else "no longer explained"
        answer = (f"{action}: after the edit ({edits}), {how} (simulated; scenario {rec.status}, causal "
                  f"{rec.causal or 'not checked'}; the behavior is {still})")
        out.append(QA("counterfactual", question, answer, "whatif verdict.causal.with_cause", ACTIONS,
                      action if action in LABELS else None))
    return out


def c_shown(run: Any, behavior: str) -> str:
    return ("shows " if run.shown else "does not show ") + behavior


def layers(scenario: Scenario, trace: Trace, verdict: Verdict, lab: Label,
           whatifs: list[dict[str, Any]] | None = None) -> list[QA]:
    """Every QA of a sample, in layer order."""
    return (perception(scenario, trace, lab) + prediction(scenario, trace, verdict, lab)
            + planning(scenario, trace, verdict, lab) + counterfactual(verdict, lab, whatifs or []))


__all__ = ["ACTIONS", "DIRECTIONS", "HORIZON", "LAYERS", "MOTIONS", "QA", "cause_actors", "counterfactual", "layers",
           "perception", "planning", "position_text", "predict", "prediction", "state_text",
           "visible_states", "where"]
