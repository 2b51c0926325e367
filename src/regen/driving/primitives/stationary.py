"""stationary: the actor stands where it starts (a parked car may open its door)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from regen.driving.primitives.base import Placed, Primitive, RuleStates, pred
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EGO_SIZE, JUNCTION_CX, EgoTemplate
from regen.driving.world.locations import LOCATIONS
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import approach


def _in_the_ego_path(m: PlacementModel, a: ActorSpec, s: Any) -> None:
    e, half = m.ego, m.half(a)
    lo = e.s_end + half + 1.0
    hi = e.s_end + half + (12.0 if e.stops else 30.0)
    m.at_least(a, f"stands in the ego's lane ahead of where the ego ends (s >= {lo:.1f} m)", s, lo)
    m.at_most(a, f"stands close enough ahead to matter (s <= {hi:.1f} m)", s, hi)


def _near_the_event(m: PlacementModel, a: ActorSpec, s: Any) -> None:
    e = m.ego
    ref = e.s_end if e.stops else e.s_event
    # an ego that waits at its event stays there: the actor must stand clear ahead of its front;
    # one that stops must still have it ahead where it comes to rest (its final state says so)
    ahead = EGO_SIZE[0] / 2 + 1.0 if e.speed_event == 0.0 and not e.stops else (1.0 if e.stops else -4.0)
    m.at_least(a, "stands ahead of the ego's event position", s, ref + m.half(a) + ahead)
    m.at_most(a, "stands within 30 m of it", s, ref + 30.0)


def _behind_the_start(m: PlacementModel, a: ActorSpec, s: Any) -> None:
    m.at_most(a, "stands behind the ego's start", s, m.ego_s(0.0) - m.half(a) - 3.0)
    m.at_least(a, "stands within 40 m behind the ego's start", s, m.ego_s(0.0) - 40.0)


def _anywhere(m: PlacementModel, a: ActorSpec, s: Any) -> None:
    """A fixed place (the junction corner): nothing to solve."""


# start location -> where along the ego's frame it stands (in the order offered)
_PLACES: dict[str, Callable[[PlacementModel, ActorSpec, Any], None]] = {
    "ahead_same_lane": _in_the_ego_path,
    "behind_same_lane": _behind_the_start,
    "ahead_adjacent_lane": _near_the_event,
    "roadside_ahead": _near_the_event,
    "roadside_opposite_ahead": _near_the_event,
    "crosswalk_ahead": _in_the_ego_path,
    "junction_corner": _anywhere,
}


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    s, v = m.start(a, speeds)
    m.m.Add(v == int(speeds[0] * DM))  # unused for stationary actors; pin it
    if a.properties.get("door") == "opens":
        t = m.trigger(a)
        te = m.ego.t_event
        m.at_least(a, "opens its door 0.3 to 2.5 s before the ego's event", t, te - 2.5)
        m.at_most(a, "opens its door at least 0.3 s before the ego's event", t, te - 0.3)
    _PLACES.get(a.location, _anywhere)(m, a, s)


def _plan(placed: Placed) -> ActorPlan:
    fr = placed.ego.frame
    loc = LOCATIONS.get(placed.actor.location)
    if loc is not None and loc.needs_junction:  # at a junction it stands at the corner
        (x, y), heading = (JUNCTION_CX - JUNCTION_RADIUS - 1.0, -(fr.lane_width + 1.5)), 0.0
    else:
        (x, y), heading = fr.point(placed.params.get("s", 0.0), placed.lateral), fr.heading
    # its state switch (a door opens, a light turns red) as the ego comes near it; what never
    # switches (no solved time) needs no trigger
    trigger = approach(placed.ego, (x, y), placed.params["t"]) if "t" in placed.params else None
    return placed.actor_plan(x=x, y=y, heading=heading, trigger=trigger)


# start location -> the cause state's name and its relations to the ego (it also stands still)
_CAUSE_PLACES: dict[str, tuple[str, tuple[str, ...]]] = {
    "ahead_same_lane": ("in_ego_path", ("same_lane", "ahead_of")),
    "crosswalk_ahead": ("in_ego_path", ("same_lane", "ahead_of")),
    "ahead_adjacent_lane": ("ahead_in_next_lane", ("adjacent_lane", "ahead_of")),
    "behind_same_lane": ("behind_ego", ("behind",)),
}
_ELSEWHERE = ("standing_ahead", ("ahead_of",))  # at the road side or the junction corner


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    name, relations = _CAUSE_PLACES.get(r.location, _ELSEWHERE)
    where = [pred(p, a, e) for p in relations]
    if r.properties.get("door") == "opens":  # the opening: closed (ahead or behind), then open where it stands
        before = [c for c in where if c.name in ("ahead_of", "behind")]  # (while the ego may still turn)
        return RuleStates(cause=(("door_closed", [pred("door_open", a, negate=True)] + before),
                                 ("door_open", [pred("door_open", a)] + where)))
    cause = (name, where + [pred("stopped", a)])
    if r.location == "behind_same_lane":
        return RuleStates(cause=(cause,))
    return RuleStates(cause=(cause,), final=("still_ahead", [pred("ahead_of", a, e)]))


SPEC = Primitive(
    name="stationary",
    users=frozenset({"vehicles", "pedestrians", "static objects"}),
    starts=tuple(_PLACES),
    speeds=None,
    moves=False,
    add_constraints=_constrain,
    build_plan=_plan,
    rule_states=_rule_states,
)
