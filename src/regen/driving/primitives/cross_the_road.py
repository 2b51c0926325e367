"""cross_the_road: a pedestrian (or a cyclist) waits at the road side, then crosses in front of
the ego.

Pedestrians walk the crossing (WalkRoute, walking speeds). A cyclist is a Scenic ``Car``: it
rides the same route across the road with FollowRoute at the speeds of a rider crossing
(:data:`RIDE_CROSS_SPEEDS`); which vehicles may cross is the asset database's ``behaviors``.
"""

from __future__ import annotations

import math
from typing import Any

from regen.driving.primitives.base import (
    ClassMotion,
    PedestrianPrimitive,
    Placed,
    RuleStates,
    SpeedClasses,
    pred,
)
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EGO_SIZE, EgoTemplate
from regen.driving.world.locations import LOCATIONS
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import approach

# A cyclist riding across the road from a standstill at the kerb: slow 1.5-2.5 m/s (5-9 km/h),
# moderate 2.5-4 m/s (9-14 km/h), fast 4-6 m/s (14-22 km/h). Slower than riding along the road:
# it sets off across traffic; a rider much faster than 4 m/s is through an ego's lane (3.5 m
# plus its own 1.8 m) in about a second, before an ego that reacted to it would get there.
RIDE_CROSS_SPEEDS = SpeedClasses(slow=(1.5, 2.5), moderate=(2.5, 4.0), fast=(4.0, 6.0))


def _walk_window(m: PlacementModel, a: ActorSpec, t: Any, v: Any, dist: float,
                 early: tuple[float, str], late: tuple[float, str]) -> None:
    """Cover ``dist`` [m] no later than ``early[0]`` s and no sooner than ``late[0]`` s before
    the ego's event (each with the words of its constraint)."""
    # time [ds] to walk `dist` [m] at v [dm/s] is dist*100/v: keep t + dist/v in a window via
    # (window - t) * v compared with dist * 100
    te = m.ego.t_event
    for tag, (offset, text), at_least in (("lo", early, True), ("hi", late, False)):
        slack = m.m.NewIntVar(-10000, 10000, f"{a.name}.slack_{tag}")
        m.m.Add(slack == int((te - offset) * DM) - t)
        prod = m.product(a.name, f"walk_{tag}", slack, v, 10 ** 7)
        m.require(f"{a.name}: {text}", prod >= int(dist * 100) if at_least else prod <= int(dist * 100))


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    e = m.ego
    fr = e.frame
    s, v = m.start(a, speeds)
    t = m.trigger(a)
    gap = abs(fr.sidewalk_d(LOCATIONS[a.location].side) - fr.lane_d(e.ego_lane))
    reach = gap - fr.lane_width / 2  # walk [m] to the ego lane's near edge
    # to its far edge [m], its back included: size[0] is its length along its heading, across
    # the road (a bicycle is 1.8 m long; pedestrians are as long as wide)
    clear = gap + fr.lane_width / 2 + a.size[0] / 2
    if e.speed_event == 0.0 and not e.stops:  # the ego waits: pedestrians clear its lane first
        lo_s, hi_s = e.s_event + EGO_SIZE[0] / 2 + 1.5, e.s_event + EGO_SIZE[0] / 2 + 8.0
        _walk_window(m, a, t, v, clear, (0.3, "has crossed the ego's lane by 0.3 s before the ego starts"),
                     (2.5, "is still crossing 2.5 s before the ego starts"))
    else:
        if e.stops:
            lo_s, hi_s = e.s_end + EGO_SIZE[0] / 2 + 1.5, e.s_end + EGO_SIZE[0] / 2 + 12.0
        else:
            lo_s, hi_s = e.s_event + 15.0, e.s_event + 35.0
        _walk_window(m, a, t, v, reach, (0.2, "reaches the ego's lane by 0.2 s before the ego's event"),
                     (1.8, "reaches the ego's lane no earlier than 1.8 s before the ego's event"))
    m.at_least(a, f"crosses ahead of where the ego ends (s >= {lo_s:.1f} m)", s, lo_s)
    m.at_most(a, f"crosses close enough to matter (s <= {hi_s:.1f} m)", s, hi_s)


def _plan(placed: Placed) -> ActorPlan:
    fr, p = placed.ego.frame, placed.params
    side = LOCATIONS[placed.actor.location].side
    s, d0 = p.get("s", 0.0), fr.sidewalk_d(side)
    route = [fr.point(s, d0), fr.point(s, -d0)]
    x, y = route[0]
    heading = fr.heading + (math.pi / 2 if side == "right" else -math.pi / 2)
    t = p.get("t", 0.0)
    # it steps out as the ego comes near where it crosses the ego's lane
    crossing = fr.point(s, fr.lane_d(placed.ego.ego_lane))
    return placed.actor_plan(x=x, y=y, heading=heading, route=route,
                             schedule=[(0.0, 0.0, 0.0), (t, p.get("v", 0.0), 0.0)],
                             trigger=approach(placed.ego, crossing, t))


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    # walking in the ego's lane ahead of it: it crosses the ego's path (merely on the road or
    # in front of the ego would also hold for one that stands there or walks along the road)
    return RuleStates(initial=("waiting", [pred("on_sidewalk", a)]),
                      cause=(("crossing", [pred("same_lane", a, e), pred("ahead_of", a, e),
                                           pred("moving", a, min_speed=0.3)]),))


SPEC = PedestrianPrimitive(name="cross_the_road",
                           # a vehicle crosses if the database lets it (the bicycle)
                           users=frozenset({"pedestrians", "vehicles"}),
                           starts=("roadside_ahead", "roadside_opposite_ahead", "crosswalk_ahead"),
                           by_class={"Car": ClassMotion(speeds=RIDE_CROSS_SPEEDS,
                                                        scenic_behavior="FollowRoute")},
                           add_constraints=_constrain, build_plan=_plan, rule_states=_rule_states)
