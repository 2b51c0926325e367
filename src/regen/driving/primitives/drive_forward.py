"""drive_forward: a vehicle drives along its lane at a constant target speed.

What it does around the ego depends on where it starts: ahead in the ego's lane it brakes
before the ego stops, departs before the waiting ego, or is a slower lead the ego catches up
with; behind it follows (and brakes after its driver's reaction time); in the next lane it
overtakes or is passed; in the oncoming lane it meets the ego.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from regen.driving.primitives.base import Placed, RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.shared import lanes, lead
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import Trigger, ego_slower

REACTION_TIME = {"attentive": 1.0, "distracted": 2.2}  # [s] before a follower brakes, by driver_state


def _reaction(a: RoleChoice) -> float:
    return REACTION_TIME.get(a.properties.get("driver_state", "attentive"), 1.0)


def _leads(m: PlacementModel, a: ActorSpec, s: Any, v: Any, s_te: Any) -> None:
    e, half, te = m.ego, m.half(a), m.ego.t_event
    if e.stops:  # it brakes first and comes to rest ahead of where the ego stops
        lead.brakes_to_a_stop(m, a, s, v)
    elif e.speed_event == 0.0:  # the ego waits behind it, then both go
        t = m.trigger(a)
        m.at_least(a, "departs 0.5 to 2 s before the ego", t, te - 2.0)
        m.at_most(a, "departs at least 0.5 s before the ego", t, te - 0.5)
        m.at_least(a, "waits 3 to 8 m ahead of the ego", s, e.s_event + half + 3.0)
        m.at_most(a, "waits at most 8 m ahead of the ego", s, e.s_event + half + 8.0)
        m.at_least(a, "drives away at least as fast as the ego (10 m/s)", v, 10.0)
    else:  # a slower lead the ego catches up with
        m.at_least(a, "is 6 to 15 m ahead of the ego at its event", s_te, e.s_event + half + 6.0)
        m.at_most(a, "is at most 15 m ahead of the ego at its event", s_te, e.s_event + half + 15.0)
        m.at_most(a, f"drives slower than the ego (v <= {e.speed_event - 3:.0f} m/s)", v, e.speed_event - 3.0)


def _follows(m: PlacementModel, a: ActorSpec, s: Any, v: Any, s_te: Any) -> None:
    e, half = m.ego, m.half(a)
    m.at_most(a, "starts behind the ego", s, m.ego_s(0.0) - half - 4.0)
    if e.stops:
        m.require(f"{a.name}: follows at the ego's speed", v == int(e.speed_event * DM))
        gap_need = e.speed_event * _reaction(a) + half + 1.0
        m.at_most(a, f"keeps a gap larger than its reaction distance ({gap_need:.1f} m) so it stops behind "
                  "the ego", s_te, e.s_event - gap_need)
        m.at_least(a, "follows within 35 m", s_te, e.s_event - 35.0)
    else:
        m.at_most(a, "stays behind the ego at its event", s_te, e.s_event - half - 5.0)
        m.at_least(a, "follows within 40 m", s_te, e.s_event - 40.0)


def _next_lane_ahead(m: PlacementModel, a: ActorSpec, s: Any, v: Any, s_te: Any) -> None:
    lanes.ahead_in_next_lane(m, a, s_te)


def _overtakes(m: PlacementModel, a: ActorSpec, s: Any, v: Any, s_te: Any) -> None:
    e, half = m.ego, m.half(a)
    lanes.overtakes(m, a, s, v)
    m.at_least(a, "is close behind the ego at its event (within 25 m)", s_te, e.s_event - 25.0)
    m.at_most(a, "has not passed the ego at its event", s_te, e.s_event - half)
    m.require(f"{a.name}: passes the ego before the end",
              10 * s + v * int(round(e.duration * DM)) >= int((e.s_end + half + 5.0) * 100))


def _oncoming(m: PlacementModel, a: ActorSpec, s: Any, v: Any, s_te: Any) -> None:
    e = m.ego
    s_meet = m.m.NewIntVar(-100000, 100000, f"{a.name}.s_meet")
    te_ds = int(round(e.t_event * DM))
    m.m.Add(10 * s_meet - 10 * s + v * te_ds >= 0)
    m.m.Add(10 * s_meet - 10 * s + v * te_ds <= 9)
    m.at_least(a, "meets the ego around its event (within 25 m ahead)", s_meet, e.s_event)
    m.at_most(a, "meets the ego within 25 m", s_meet, e.s_event + 25.0)


def _leading_states(a: str, t: EgoTemplate) -> RuleStates:
    e = "ego"
    if t.stops:  # it brakes in front of the ego
        return lead.braking_states(a, t)
    if t.speed_event == 0.0:  # it waits in front of the ego, then departs
        return RuleStates(
            cause=(("waiting_ahead", [pred("stopped", a), pred("in_front", a, e, distance=20.0)]),
                   ("departing", [pred("moving", a), pred("in_front", a, e, distance=30.0)])))
    # a slower lead in the ego's lane that the ego catches up with
    return RuleStates(initial=("leading", [pred("ahead_of", a, e), pred("moving", a)]),
                      cause=(("close_ahead", [pred("in_front", a, e, distance=40.0), pred("moving", a),
                                              pred("slower_than", a, max_speed=t.speed_event - 2.0)]),))


def _following_states(a: str, t: EgoTemplate) -> RuleStates:
    e = "ego"
    return RuleStates(initial=("following", [pred("behind", a, e), pred("moving", a)]),
                      cause=(("close_behind", [pred("behind", a, e), pred("same_lane", a, e),
                                               pred("close_to", a, e, distance=40.0)]),),
                      final=("behind_ego", [pred("behind", a, e)]))


def _next_lane_states(a: str, t: EgoTemplate) -> RuleStates:
    e = "ego"
    return RuleStates(cause=(("ahead_in_next_lane", [pred("ahead_of", a, e), pred("adjacent_lane", a, e),
                                                     pred("moving", a)]),))


def _overtaking_states(a: str, t: EgoTemplate) -> RuleStates:
    e = "ego"
    return RuleStates(initial=("approaching", [pred("behind", a, e), pred("moving", a)]),
                      cause=(("close_behind", [pred("behind", a, e), pred("adjacent_lane", a, e),
                                               pred("close_to", a, e, distance=30.0)]),),
                      final=("passing", [pred("ahead_of", a, e), pred("moving", a)]))


def _oncoming_states(a: str, t: EgoTemplate) -> RuleStates:
    e = "ego"
    return RuleStates(initial=("oncoming", [pred("ahead_of", a, e), pred("moving", a)]),
                      cause=(("close", [pred("ahead_of", a, e), pred("moving", a),
                                        pred("close_to", a, e, distance=25.0)]),))


def _steady(placed: Placed) -> tuple[float, float]:
    return 0.0, 0.0


def _no_trigger(placed: Placed) -> Trigger | None:
    return None


def _following_trigger(placed: Placed) -> Trigger | None:
    """It brakes its reaction time after the ego brakes hard (measured from the ego's speed)."""
    return ego_slower(placed.ego) if placed.ego.stops else None


def _leading_timing(placed: Placed) -> tuple[float, float]:
    ego, p = placed.ego, placed.params
    if "t" not in p:
        return 0.0, 0.0
    if ego.stops:
        return 0.0, p["t"]
    return (p["t"], 0.0) if ego.speed_event == 0.0 else (0.0, 0.0)


def _following_timing(placed: Placed) -> tuple[float, float]:
    ego = placed.ego
    return 0.0, (ego.t_event + _reaction(placed.actor) if ego.stops else 0.0)


@dataclass(frozen=True, kw_only=True)
class _Start:
    """What drive_forward does from one start location."""

    constrain: Callable[[PlacementModel, ActorSpec, Any, Any, Any], None]  # given s, v and s_te
    states: Callable[[str, EgoTemplate], RuleStates]  # its rule states (actor name, ego template)
    timing: Callable[[Placed], tuple[float, float]] = _steady  # when it departs, brakes [s] (0: never)
    trigger: Callable[[Placed], Trigger | None] = _no_trigger  # what starts that (None: steady traffic)
    towards_ego: bool = False  # drives against the ego's direction


# start location -> what it does from there (in the order offered)
_STARTS: dict[str, _Start] = {
    "ahead_same_lane": _Start(constrain=_leads, states=_leading_states, timing=_leading_timing,
                              trigger=lead.brake_trigger),
    "behind_same_lane": _Start(constrain=_follows, states=_following_states, timing=_following_timing,
                               trigger=_following_trigger),
    "ahead_adjacent_lane": _Start(constrain=_next_lane_ahead, states=_next_lane_states),
    "behind_adjacent_lane": _Start(constrain=_overtakes, states=_overtaking_states),
    "oncoming_lane": _Start(constrain=_oncoming, states=_oncoming_states, towards_ego=True),
}


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    s, v = m.start(a, speeds)
    s_te = lanes.s_at_event(m, a, s, v)
    _STARTS[a.location].constrain(m, a, s, v, s_te)


def _plan(placed: Placed) -> ActorPlan:
    start = _STARTS[placed.actor.location]
    fr, p = placed.ego.frame, placed.params
    s, v = p.get("s", 0.0), p.get("v", 0.0)
    sign = -1.0 if start.towards_ego else 1.0
    route = lanes.straight(fr, s, s + sign * lanes.ROUTE_AHEAD, placed.lateral)
    x, y = route[0]
    departs, brakes = start.timing(placed)
    schedule = [(0.0, v, 0.0)]
    speed0 = v
    if departs > 0:  # waits stationary, then departs
        schedule = [(0.0, 0.0, 1.0), (departs, v, 0.0)]
        speed0 = 0.0
    if brakes > 0:
        schedule.append((brakes, 0.0, 1.0))
    heading = fr.heading if sign > 0 else fr.heading + math.pi
    return placed.actor_plan(x=x, y=y, heading=heading, speed0=speed0, route=route, schedule=schedule,
                             trigger=start.trigger(placed))


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    return _STARTS[r.location].states(r.name, t)


SPEC = VehiclePrimitive(name="drive_forward", starts=tuple(_STARTS), add_constraints=_constrain,
                        build_plan=_plan, rule_states=_rule_states)
