"""A vehicle ahead of the ego in its lane that brakes in front of it: shared by ``drive_forward``
(from ``ahead_same_lane``, around an ego that stops) and ``brake_ahead`` (a lead that brakes
hard, the text's 'the car ahead stops abruptly', around an ego that stops or slows down)."""

from __future__ import annotations

from typing import Any

from regen.driving.primitives.base import Placed, RuleStates, pred
from regen.driving.world.actors import ActorSpec
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.triggers import Trigger, approach

FULL_BRAKE = 6.8  # [m/s^2] at brake level 1 (the plan's schedule), after 0.1 s to build up
SLOW_LEVEL = 0.5  # brake level of a lead that slows down hard without stopping


def brakes_to_a_stop(m: PlacementModel, a: ActorSpec, s: Any, v: Any) -> None:
    """It brakes 0.3 to 1.5 s before the ego stops and comes to rest 1.5 to 10 m ahead of where
    the ego stops."""
    e, half, te = m.ego, m.half(a), m.ego.t_event
    t = m.trigger(a)
    m.at_least(a, f"brakes 0.3 to 1.5 s before the ego (t={te:.1f} s)", t, te - 1.5)
    m.at_most(a, "brakes at least 0.3 s before the ego", t, te - 0.3)
    vt = m.product(a.name, "vt", v, t, 10 ** 7)
    sq = m.product(a.name, "v2", v, v, 10 ** 6)
    stop = m.m.NewIntVar(-100000, 100000, f"{a.name}.stop")  # [dm] where it comes to rest
    m.m.Add(1360 * stop >= 1360 * s + 136 * vt + 10 * sq + 140 * v - 1360)
    m.m.Add(1360 * stop <= 1360 * s + 136 * vt + 10 * sq + 140 * v + 1360)
    m.at_least(a, "stops ahead of where the ego stops, with a gap of 1.5 to 10 m", stop, e.s_end + half + 1.5)
    m.at_most(a, "stops at most 10 m ahead of the ego's stop", stop, e.s_end + half + 10.0)
    m.at_least(a, f"drives at least as fast as the ego (v >= {e.speed_event:.0f} m/s)", v, e.speed_event)
    m.at_least(a, "starts ahead of the ego", s, m.ego_s(0.0) + half + 3.0)


def slow_speed(e: EgoTemplate) -> float:
    """[m/s] the speed an ego that slows down slows to (its schedule's last speed)."""
    return min(speed for _, speed, _ in e.schedule)


def brakes_to_slow(m: PlacementModel, a: ActorSpec, s: Any, v: Any) -> None:
    """Around an ego that slows down: it drives at the ego's speed, brakes hard 0.3 to 1.5 s
    before the ego slows, down to the speed the ego slows to, and is 8 to 25 m ahead of the ego
    (bumper to bumper) when it brakes."""
    e, half, te = m.ego, m.half(a), m.ego.t_event
    m.at_least(a, f"drives at the ego's speed (v >= {e.speed_event - 1:.0f} m/s)", v, e.speed_event - 1.0)
    m.at_most(a, f"drives at the ego's speed (v <= {e.speed_event + 1:.0f} m/s)", v, e.speed_event + 1.0)
    t = m.trigger(a)
    m.at_least(a, f"brakes 0.3 to 1.5 s before the ego slows (t={te:.1f} s)", t, te - 1.5)
    m.at_most(a, "brakes at least 0.3 s before the ego slows", t, te - 0.3)
    vt = m.product(a.name, "vt", v, t, 10 ** 7)
    ego_t = int(e.speed_event * DM) * t  # [dm * ds] the ego's travel until t, times 10
    lo, hi = (int((m.ego_s(0.0) + half + d) * 100) for d in (8.0, 25.0))
    m.require(f"{a.name}: is 8 to 25 m ahead of the ego when it brakes", 10 * s + vt - ego_t >= lo)
    m.require(f"{a.name}: is at most 25 m ahead of the ego when it brakes", 10 * s + vt - ego_t <= hi)


def braking_states(a: str, t: EgoTemplate) -> RuleStates:
    """Leading, braking in front of the ego, then stopped ahead of it (an ego that stops) or
    driving slowly ahead of it (one that slows down)."""
    e = "ego"
    if t.stops:
        final = ("stopped_ahead", [pred("stopped", a), pred("ahead_of", a, e)])
    else:
        final = ("slow_ahead", [pred("ahead_of", a, e), pred("slower_than", a, max_speed=slow_speed(t) + 1.0)])
    return RuleStates(initial=("leading", [pred("in_front", a, e, distance=60.0), pred("moving", a)]),
                      cause=(("braking", [pred("braking", a, min_decel=3.0),
                                          pred("in_front", a, e, distance=60.0)]),),
                      final=final)


def brake_trigger(placed: Placed) -> Trigger | None:
    """It brakes as the ego comes near where it brakes in the template, or (a lead the waiting
    ego follows) departs at its time: :func:`~regen.driving.world.triggers.approach` makes that a
    time trigger."""
    ego, p = placed.ego, placed.params
    if "t" not in p:
        return None
    s_brake = p.get("s", 0.0) + p.get("v", 0.0) * p["t"]
    return approach(ego, ego.frame.point(s_brake, placed.lateral), p["t"])
