"""OpenSCENARIO storyboard events for actors whose cause action starts on a trigger
(:mod:`regen.driving.world.triggers`), so another player's ego meets the cause wherever it is.

An actor with a trigger gets two events in its maneuver: its motion before the trigger fired in
the recording (on simulation time, as recorded) and its cause action: the rest of its recorded
path as a trajectory timed *from the event's start*, started by the condition its trigger fires
on, with the ego as the triggering entity:

==============  =====================================================================================
trigger kind    start condition
==============  =====================================================================================
time            SimulationTimeCondition: time >= the trigger time
approach, near DistanceCondition (ego within the straight-line distance of the trigger point at
                which the recorded ego set it off) OR TimeToCollisionCondition (that distance
                over its speed then), two groups
ego_slower      SpeedCondition: the ego slower than the trigger speed
offset          RelativeDistanceCondition (the actor as far ahead of the ego, longitudinally, as in
                the template) OR SimulationTimeCondition (the trigger's latest time)
==============  =====================================================================================

Approximations, documented in ``docs/interop.md``: distances are Euclidean where the project
measures along the road plus aside; the motion after the trigger is the recorded path, not a
controller. Imports: this domain's world (triggers) and scenariogeneration.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from regen.core.trace import Trace
from regen.driving.world.triggers import Spec, warped_time


def fire_index(spec: Spec, trace: Trace, actor: str | None = None) -> int | None:
    """The step at which ``spec`` fired in the recording for ``actor`` (its position counts for
    an offset trigger; None: it never did)."""
    ego = trace.actors.get("ego")
    if ego is None:
        return None
    own = trace.actors.get(actor) if actor is not None else None
    t_fire = None
    for k, t in enumerate(trace.times):
        ax, ay = (own.x[k], own.y[k]) if own is not None and k < len(own.x) else (None, None)
        t_fire, _ = warped_time(spec, t_fire, t, ego.x[k], ego.y[k], ego.speed[k], ax, ay)
        if t_fire is not None:
            return k
    return None


def as_recorded(spec: Spec, trace: Trace, k_fire: int | None) -> Spec:
    """``spec`` with an approach measured as OpenSCENARIO measures it: the straight-line distance
    (and that distance over the ego's speed) at which the recorded ego set it off, so a player
    fires it at the same step for the same ego (the project measures along the road plus aside,
    which a DistanceCondition cannot state)."""
    ego = trace.actors.get("ego")
    if spec[0] != "approach" or k_fire is None or ego is None:
        return spec
    d = np.hypot(spec[2] - np.asarray(ego.x[: k_fire + 1]), spec[3] - np.asarray(ego.y[: k_fire + 1]))
    v = np.asarray(ego.speed[: k_fire + 1], float)
    tta = np.where(v > 0.5, d / np.maximum(v, 1e-9), np.inf)
    # the values at the fire, but below what any earlier step had: neither condition holds sooner
    near = min(float(d[-1]), float(d[:-1].min()) - 1e-3) if k_fire else float(d[-1])
    t_a = min(float(tta[-1]), float(tta[:-1].min()) - 1e-3) if k_fire else float(tta[-1])
    t_a = round(t_a, 4) if spec[7] > 0 and np.isfinite(t_a) and t_a > 0 else 0.0
    return (spec[0], spec[1], spec[2], spec[3], spec[4], spec[5], round(max(near, 0.0), 4), t_a, *spec[8:])


def start_trigger(xosc: Any, name: str, spec: Spec, ego: str, actor: str, delay: float = 0.0):
    """The storyboard trigger that starts ``actor``'s cause action (see the module docstring),
    ``delay`` [s] after its condition holds."""
    kind, t_trig, px, py, _ux, _uy, near, tta, below, offset, rate, late = spec
    delay = round(max(0.0, float(delay)), 4)
    if kind == "time":
        return xosc.ValueTrigger(f"{name}_time", 0, xosc.ConditionEdge.none,
                                 xosc.SimulationTimeCondition(round(float(t_trig) + delay, 4), xosc.Rule.greaterOrEqual))
    trigger = xosc.Trigger()
    groups: list[Any] = []
    if kind in ("approach", "near"):
        point = xosc.WorldPosition(float(px), float(py), 0.0, 0.0)
        if near >= 0:  # an imported 'near' without a distance has a negative one
            groups.append(xosc.EntityTrigger(f"{name}_near", delay, xosc.ConditionEdge.none, xosc.DistanceCondition(
                float(near), xosc.Rule.lessOrEqual, point, alongroute=False, freespace=False,
                distance_type=xosc.RelativeDistanceType.euclidianDistance), ego))
        if tta > 0:
            groups.append(xosc.EntityTrigger(f"{name}_tta", delay, xosc.ConditionEdge.none, xosc.TimeToCollisionCondition(
                float(tta), xosc.Rule.lessOrEqual, alongroute=False, freespace=False, position=point,
                distance_type=xosc.RelativeDistanceType.euclidianDistance), ego))
    elif kind == "ego_slower":
        groups.append(xosc.EntityTrigger(f"{name}_slower", delay, xosc.ConditionEdge.none,
                                         xosc.SpeedCondition(float(below), xosc.Rule.lessThan), ego))
    elif kind == "offset":
        rule = xosc.Rule.greaterOrEqual if rate >= 0 else xosc.Rule.lessOrEqual
        groups.append(xosc.EntityTrigger(f"{name}_offset", delay, xosc.ConditionEdge.none, xosc.RelativeDistanceCondition(
            float(offset), rule, xosc.RelativeDistanceType.longitudinal, ego, alongroute=False, freespace=False),
            actor))
        groups.append(xosc.ValueTrigger(f"{name}_latest", delay, xosc.ConditionEdge.none,
                                        xosc.SimulationTimeCondition(float(late), xosc.Rule.greaterOrEqual)))
    else:
        raise ValueError(f"unknown trigger kind {kind!r}")
    for g in groups:  # condition groups are OR-ed
        trigger.add_conditiongroup(xosc.ConditionGroup().add_condition(g))
    return trigger


def _follow(xosc: Any, name: str, positions: list[Any], times: np.ndarray, *, relative: bool):
    poly = xosc.Polyline([float(t - times[0]) for t in times] if relative else [float(t) for t in times], positions)
    traj = xosc.Trajectory(f"{name}_path", False)
    traj.add_shape(poly)
    # position mode: where and when the recording has it; relative timing starts at the event
    return xosc.FollowTrajectoryAction(traj, xosc.FollowingMode.position,
                                       xosc.ReferenceContext.relative if relative else xosc.ReferenceContext.absolute,
                                       1, 0)


def triggered_group(xosc: Any, name: str, positions: list[Any], times: np.ndarray, k_fire: int, spec: Spec,
                    ego: str, *, moves_before: bool):
    """The maneuver group of a triggered actor: its motion before the trigger (if it moves then,
    on simulation time) and its cause action from the trigger's condition on."""
    maneuver = xosc.Maneuver(f"{name}_maneuver")
    if moves_before and k_fire >= 2:
        before = xosc.Event(f"{name}_before_trigger", xosc.Priority.override)
        before.add_action(f"{name}_approach", _follow(xosc, f"{name}_before", positions[: k_fire + 1],
                                                      times[: k_fire + 1], relative=False))
        before.add_trigger(xosc.ValueTrigger(f"{name}_at_start", 0, xosc.ConditionEdge.none,
                                             xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual)))
        maneuver.add_event(before)
    cause = xosc.Event(f"{name}_cause", xosc.Priority.override)
    cause.add_action(f"{name}_cause_action", _follow(xosc, f"{name}_cause", positions[k_fire:], times[k_fire:],
                                                     relative=True))
    cause.add_trigger(start_trigger(xosc, name, spec, ego, name))
    maneuver.add_event(cause)
    group = xosc.ManeuverGroup(f"{name}_group")
    group.add_actor(name)
    group.add_maneuver(maneuver)
    return group


def state_group(xosc: Any, name: str, changes: list[tuple[float, str, Any]], spec: Spec | None, ego: str):
    """The maneuver group of an actor's state changes (a traffic light's signal, a door, a
    siren): one event per change ``(t [s], label, action)`` after the start, each started by the
    actor's trigger (its condition on the ego) with the change's delay after the trigger's time,
    or at its time when the actor has no trigger."""
    maneuver = xosc.Maneuver(f"{name}_states")
    for i, (t, label, action) in enumerate(changes):
        event = xosc.Event(f"{name}_{label}_{i}", xosc.Priority.parallel)
        event.add_action(f"{name}_{label}_{i}_action", action)
        if spec is None:
            event.add_trigger(xosc.ValueTrigger(f"{name}_{label}_{i}_time", 0, xosc.ConditionEdge.none,
                                                xosc.SimulationTimeCondition(round(float(t), 4), xosc.Rule.greaterOrEqual)))
        else:
            event.add_trigger(start_trigger(xosc, f"{name}_{label}_{i}", spec, ego, name, delay=t - float(spec[1])))
        maneuver.add_event(event)
    group = xosc.ManeuverGroup(f"{name}_state_group")
    group.add_actor(name)
    group.add_maneuver(maneuver)
    return group


__all__ = ["as_recorded", "fire_index", "start_trigger", "state_group", "triggered_group"]
