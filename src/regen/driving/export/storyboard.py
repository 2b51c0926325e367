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
approach, near DistanceCondition (ego within the trigger distance of the trigger point) OR
                TimeToCollisionCondition (ego's time to reach that point <= the trigger's), two groups
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


def start_trigger(xosc: Any, name: str, spec: Spec, ego: str, actor: str):
    """The storyboard trigger that starts ``actor``'s cause action (see the module docstring)."""
    kind, t_trig, px, py, _ux, _uy, near, tta, below, offset, rate, late = spec
    if kind == "time":
        return xosc.ValueTrigger(f"{name}_time", 0, xosc.ConditionEdge.none,
                                 xosc.SimulationTimeCondition(float(t_trig), xosc.Rule.greaterOrEqual))
    trigger = xosc.Trigger()
    groups: list[Any] = []
    if kind in ("approach", "near"):
        point = xosc.WorldPosition(float(px), float(py), 0.0, 0.0)
        if near >= 0:  # an imported 'near' without a distance has a negative one
            groups.append(xosc.EntityTrigger(f"{name}_near", 0, xosc.ConditionEdge.none, xosc.DistanceCondition(
                float(near), xosc.Rule.lessOrEqual, point, alongroute=False, freespace=False,
                distance_type=xosc.RelativeDistanceType.euclidianDistance), ego))
        if tta > 0:
            groups.append(xosc.EntityTrigger(f"{name}_tta", 0, xosc.ConditionEdge.none, xosc.TimeToCollisionCondition(
                float(tta), xosc.Rule.lessOrEqual, alongroute=False, freespace=False, position=point,
                distance_type=xosc.RelativeDistanceType.euclidianDistance), ego))
    elif kind == "ego_slower":
        groups.append(xosc.EntityTrigger(f"{name}_slower", 0, xosc.ConditionEdge.none,
                                         xosc.SpeedCondition(float(below), xosc.Rule.lessThan), ego))
    elif kind == "offset":
        rule = xosc.Rule.greaterOrEqual if rate >= 0 else xosc.Rule.lessOrEqual
        groups.append(xosc.EntityTrigger(f"{name}_offset", 0, xosc.ConditionEdge.none, xosc.RelativeDistanceCondition(
            float(offset), rule, xosc.RelativeDistanceType.longitudinal, ego, alongroute=False, freespace=False),
            actor))
        groups.append(xosc.ValueTrigger(f"{name}_latest", 0, xosc.ConditionEdge.none,
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


__all__ = ["fire_index", "start_trigger", "triggered_group"]
