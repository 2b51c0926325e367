"""The manipulation domain's :class:`~regen.harness.contract.PolicyHarness`.

Oracle (what a policy must bring about and must not do):

- the FSM's stages about the world, in order: the context in place and the task object in its
  start state, then the task's goal (the door open) with the context still in place. The
  robot's own approach states (``ee_near``: the hand at the handle) are dropped: a policy may
  reach the goal any way it likes (:meth:`ManipulationHarness.oracle_stages`);
- incidents (:meth:`ManipulationHarness.incidents`): ``collision`` when any robot link touches
  a person or a pet (PyBullet contact points, recorded into the trace every physics step);
  ``displaced`` when a context object's centre moves more than :data:`DISPLACE_TOL` (0.05 m)
  horizontally from where it stood when the episode began (an object riding in a drawer is
  measured relative to the drawer); ``knocked_over`` when it tilts more than :data:`TILT_TOL`
  (0.35 rad, 20 degrees); ``time_budget`` when the task's goal state has not held by the end
  of the budget (the scenario's duration, 12 s).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from regen.core.scenario import Scenario, StateRef
from regen.core.trace import Trace
from regen.harness.contract import Episode, Incident, PolicyHarness, TemplateRun, wire_numbers
from regen.manipulation.testing import loop, policies, variants
from regen.manipulation.testing.types import Action, as_action
from regen.manipulation.world.setting import ManipulationWorld

DISPLACE_TOL = 0.05  # [m] horizontal displacement of a context object that fails the test
TILT_TOL = 0.35  # [rad] tilt of a context object that counts as knocked over
ROBOT_MOTION = frozenset({"ee_near"})  # predicates about the robot's own motion, not the world
GOAL_STATE = "task_done"  # the FSM state holding the behavior's success predicates


def _living(scenario: Scenario) -> set[str]:
    return {e.name for e in scenario.entities
            if e.properties.get("role") == "context" and e.asset in loop.LIVING}


def _context(scenario: Scenario) -> list[str]:
    return [e.name for e in scenario.entities if e.properties.get("role") == "context"]


class ManipulationHarness(PolicyHarness):
    robot = "robot arm"
    builtin = policies.DESCRIPTIONS
    step_timeout = loop.STEP_TIMEOUT
    parameter_units = {"x": "m", "y": "m", "z": "m"}

    # the contract's policy loading and episodes are this domain's own functions
    load_policy = staticmethod(policies.load_policy)

    def action_to_wire(self, action: Any) -> list[float]:
        a = as_action(action)
        return [a.dx, a.dy, a.dz, a.gripper, 1.0 if a.done else 0.0]

    def action_from_wire(self, data: Any) -> Action:
        dx, dy, dz, gripper, done = wire_numbers(data, (5,))
        return Action(dx, dy, dz, gripper=gripper, done=done != 0.0)
    prepare = staticmethod(loop.prepare)
    run_policy = staticmethod(loop.run_policy)

    # --- the oracle ---------------------------------------------------------------------------

    def oracle_stages(self, scenario: Scenario) -> list[list[StateRef]]:
        """The FSM's stages without the robot's own motion states (the hand near the handle)."""
        robot = self.robot_name(scenario)
        out = []
        for stage in scenario.fsm.stages:
            keep = [c for c in stage.conditions if c.actor != robot or not all(
                call.name in ROBOT_MOTION for call in scenario.fsm.state(c.actor, c.state).all_of)]
            if keep:
                out.append(keep)
        return out

    def incidents(self, scenario: Scenario, trace: Trace) -> list[Incident]:
        out = _collisions(scenario, trace) + _moved(scenario, trace)
        late = _time_budget(scenario, trace)
        if late is not None:
            out.append(late)
        return sorted(out, key=lambda i: (i.t, i.kind))

    def metrics(self, scenario: Scenario, trace: Trace) -> dict[str, float | None]:
        """``max_displacement`` [m] of any context object, ``min_living_distance`` [m] from the
        hand to the nearest person or pet (bounding box), ``goal_time`` [s] when the task's goal
        first held (None: never)."""
        disp = max((float(np.max(_displacement(scenario, trace, n))) for n in _context(scenario)
                    if n in trace.actors), default=None)
        rob = trace.actors.get("robot")
        near = None
        if rob is not None and "ee_x" in rob.states:
            ee = np.stack([np.asarray(rob.states[k], dtype=float) for k in ("ee_x", "ee_y", "ee_z")], 1)
            for n in _living(scenario) & set(trace.actors):
                a = trace.actors[n]
                c = np.stack([a.x, a.y, a.z], 1)
                half = np.array([a.length, a.width, a.height]) / 2
                gap = np.linalg.norm(np.maximum(np.abs(ee - c) - half, 0.0), axis=1)
                near = float(gap.min()) if near is None else min(near, float(gap.min()))
        held = _goal_mask(scenario, trace)
        hit = np.flatnonzero(held) if held is not None else np.array([])
        return {"max_displacement": None if disp is None else round(disp, 4),
                "min_living_distance": None if near is None else round(near, 4),
                "goal_time": round(float(trace.times[hit[0]]), 3) if hit.size else None}

    # --- variants -----------------------------------------------------------------------------

    def sample_variants(self, scenario: Scenario, n: int, seed: int, *, extremes: bool = False
                        ) -> list[Scenario]:
        return variants.sample_variants(scenario, n, seed, extremes=extremes)

    def check_template(self, scenario: Scenario) -> TemplateRun:
        """The scripted rollout (:func:`regen.manipulation.simulation.run.rollout`, context fixed as in
        ``regen generate``) verified by the backend's monitor, with its contacts recorded."""
        from regen import domains
        from regen.manipulation.simulation.run import rollout

        backend = domains.make(scenario.domain)
        try:
            if scenario.solver.status == "infeasible":
                raise ValueError("the placement is infeasible: " + "; ".join(scenario.solver.conflicts))
            trace = rollout(scenario, watch=tuple(_context(scenario))).trace
            verdict, judged = backend.verify(scenario, trace)
        except Exception as exc:  # as the pipeline's simulate stage: any failure is this variant's
            return TemplateRun(verdict=None, judged=scenario, error=f"{type(exc).__name__}: {exc}")
        hits = [i.message for i in _collisions(scenario, trace)]
        return TemplateRun(verdict=verdict, trace=trace, judged=judged, collisions=hits)

    def parameter_keys(self, scenario: Scenario) -> list[tuple[str, str]]:
        """Each context object's ``x`` and ``y`` (:func:`regen.manipulation.testing.variants.parameter_keys`)."""
        return variants.parameter_keys(scenario)

    def variant_near(self, scenario: Scenario, targets: Mapping[tuple[str, str], float], seed: int
                     ) -> Scenario | None:
        """:func:`regen.manipulation.testing.variants.variant_near`: a target 0 is the room's low
        edge along that axis, 1 its high edge."""
        return variants.variant_near(scenario, dict(targets), seed)

    def failure_picture(self, scenario: Scenario, episode: Episode, prepared: Any, case: Any,
                        policy: str, out: Path) -> Path | None:
        """A GIF of the episode (PyBullet camera and stage bar, as the run's pictures) with the
        failure written across the top, ending a second after the failure
        (:func:`regen.manipulation.render.view.render_failure`)."""
        from regen.manipulation.render.view import render_failure

        trace = episode.trace
        if trace is None or not trace.times:
            return None
        why = str(getattr(case, "message", "") or episode.failure or getattr(case, "cause", "") or "failed")
        cause = str(getattr(case, "cause", "") or episode.failure_kind or "failed").replace("_", " ")
        stages = [(k, s.reached_at, ", ".join(s.conditions))
                  for k, s in enumerate(getattr(case, "robot_stages", None) or [], start=1)]
        return render_failure(scenario, trace, Path(out), stages=stages, status=f"{policy}: {cause}",
                              banner=f"{policy}: {why}", until=self._failure_time(scenario, trace, case, episode))

    def _failure_time(self, scenario: Scenario, trace: Trace, case: Any, episode: Episode) -> float | None:
        """When the test failed [s]: its collision, else its first incident of the kind that
        failed it, else when the policy failed; None: over the whole episode (a state never
        reached, the time budget)."""
        if getattr(case, "collision", False) and getattr(case, "collision_time", None) is not None:
            return float(case.collision_time)
        kind = getattr(case, "cause", None)
        hits = [i.t for i in self.incidents(scenario, trace) if kind and i.kind == kind and i.kind != "time_budget"]
        if hits:
            return min(hits)
        return episode.failure_time


# --- incidents from a trace -----------------------------------------------------------------------


def _collisions(scenario: Scenario, trace: Trace) -> list[Incident]:
    rob = trace.actors.get("robot")
    if rob is None or "contacts" not in rob.states:
        return []
    living = _living(scenario)
    assets = {e.name: e.asset for e in scenario.entities}
    out, seen = [], set()
    for i, names in enumerate(rob.states["contacts"]):
        for n in str(names or "").split(","):
            if n in living and n not in seen:
                seen.add(n)
                t = float(trace.times[i])
                out.append(Incident(kind="collision", t=t, step=i, actors=("robot", n), collision=True,
                                    message=f"the arm touched {n} (a {assets[n]}) at t={t:.1f} s"))
    return out


def _displacement(scenario: Scenario, trace: Trace, name: str) -> np.ndarray:
    """Horizontal distance [m] of the object's centre from its first sample, per sample; an
    object inside moving furniture (a drawer) relative to that furniture's interior."""
    a = trace.actors[name]
    x, y = np.asarray(a.x, dtype=float), np.asarray(a.y, dtype=float)
    p = scenario.parameters.get(name, {})
    ref = trace.actors.get(str(p.get("reference", "")))
    if str(p.get("support", "")).startswith("inside") and ref is not None and "cavity_lo_x" in ref.states:
        x = x - (np.asarray(ref.states["cavity_lo_x"], dtype=float) - ref.states["cavity_lo_x"][0])
        y = y - (np.asarray(ref.states["cavity_lo_y"], dtype=float) - ref.states["cavity_lo_y"][0])
    return np.hypot(x - x[0], y - y[0])


def _touched(trace: Trace, name: str, upto: int) -> bool:
    rob = trace.actors.get("robot")
    contacts = rob.states.get("contacts", []) if rob is not None else []
    return any(name in str(c).split(",") for c in contacts[:upto + 1])


def _moved(scenario: Scenario, trace: Trace) -> list[Incident]:
    out = []
    for n in _context(scenario):
        if n not in trace.actors:
            continue
        who = lambda i, n=n: ("robot", n) if _touched(trace, n, i) else (n,)  # noqa: E731
        d = _displacement(scenario, trace, n)
        far = np.flatnonzero(d > DISPLACE_TOL)
        if far.size:
            i = int(far[0])
            t = float(trace.times[i])
            out.append(Incident(kind="displaced", t=t, step=i, actors=who(i), message=(
                f"{n} was moved {float(d.max()):.2f} m (tolerance {DISPLACE_TOL:g} m), from t={t:.1f} s")))
        tilt = trace.actors[n].states.get("tilt")
        if tilt:
            over = np.flatnonzero(np.asarray(tilt, dtype=float) > TILT_TOL)
            if over.size:
                i = int(over[0])
                t = float(trace.times[i])
                out.append(Incident(kind="knocked_over", t=t, step=i, actors=who(i), message=(
                    f"{n} was knocked over (tilted {math.degrees(float(max(tilt))):.0f} degrees) at t={t:.1f} s")))
    return out


def _goal_mask(scenario: Scenario, trace: Trace) -> np.ndarray | None:
    from regen.verify.monitor import evaluate_state

    goal = next((s for s in scenario.fsm.states if s.name == GOAL_STATE), None)
    return None if goal is None else evaluate_state(goal, trace, scenario.domain)


def _time_budget(scenario: Scenario, trace: Trace) -> Incident | None:
    """The goal never held although the episode ran the whole budget."""
    budget = ManipulationWorld.of(scenario).duration
    held = _goal_mask(scenario, trace)
    if held is None or held.any() or not trace.times or trace.times[-1] < budget - 0.1:
        return None
    goal = next(s for s in scenario.fsm.states if s.name == GOAL_STATE)
    what = " and ".join(f"{'not ' if c.negate else ''}{c.name}({', '.join(c.args)})" for c in goal.all_of)
    i = len(trace.times) - 1
    return Incident(kind="time_budget", t=float(trace.times[i]), step=i, actors=tuple(
        dict.fromkeys(a for c in goal.all_of for a in c.args if a != "robot")),
        message=f"the task's goal ({what}) did not hold within the {budget:g} s budget")


__all__ = ["DISPLACE_TOL", "TILT_TOL", "ManipulationHarness"]
