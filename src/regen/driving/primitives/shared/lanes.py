"""What the primitives of vehicles in the ego's road share: routes along the frame, the
position at the ego's event, the overtaking and the ahead-in-the-next-lane windows, the lane
change relative to the ego."""

from __future__ import annotations

from typing import Any

from regen.driving.primitives.base import LANE_CHANGE_LENGTH, Placed
from regen.driving.world.actors import ActorSpec
from regen.driving.world.egos import Frame
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan, LaneChange
from regen.driving.world.triggers import offset_reached

ROUTE_AHEAD = 400.0  # [m] a route runs this far along the frame
# [s] (template time) a lane change is laid out this long before it starts, so that the route
# follower's look-ahead (4 m, or 0.8 s of driving above 5 m/s: at most 1.4 s at 3 m/s) meets it
# on the laid-out route as it does on the template's
LAY_OUT = 2.0


def straight(fr: Frame, s0: float, s1: float, d: float, step: float = 5.0) -> list[tuple[float, float]]:
    """Points [m] every ``step`` m from ``s0`` to ``s1`` along the frame at lateral offset ``d``."""
    n = max(1, int(abs(s1 - s0) // step))
    return [fr.point(s0 + (s1 - s0) * i / n, d) for i in range(n + 1)]


def s_at_event(m: PlacementModel, a: ActorSpec, s: Any, v: Any) -> Any:
    """Where [dm] the actor is at the ego's event if it keeps its speed from the start."""
    s_te = m.m.NewIntVar(-100000, 100000, f"{a.name}.s_te")
    te_ds = int(round(m.ego.t_event * DM))
    m.m.Add(10 * s_te - 10 * s - v * te_ds >= 0)
    m.m.Add(10 * s_te - 10 * s - v * te_ds <= 9)
    return s_te


def overtakes(m: PlacementModel, a: ActorSpec, s: Any, v: Any) -> None:
    """Starts behind the ego in the next lane and drives faster than it."""
    e = m.ego
    m.at_most(a, "starts behind the ego", s, m.ego_s(0.0) - m.half(a) - 5.0)
    m.at_least(a, f"is faster than the ego (v >= {e.speed_event + 2:.0f} m/s)", v, e.speed_event + 2.0)


def ahead_in_next_lane(m: PlacementModel, a: ActorSpec, s_te: Any) -> None:
    """Is 3 to 30 m ahead of the ego in the next lane at the ego's event."""
    e, half = m.ego, m.half(a)
    m.at_least(a, "is 3 to 30 m ahead of the ego at its event", s_te, e.s_event + half + 3.0)
    m.at_most(a, "is at most 30 m ahead of the ego at its event", s_te, e.s_event + half + 30.0)


def lane_change_plan(placed: Placed) -> ActorPlan:
    """Along its lane at speed v until t, then over into the ego's lane (change_lane, cut_in).

    Relative to the ego: it keeps pace with the ego, and its lane change is laid out when it is
    as far ahead of the ego as in the template :data:`LAY_OUT` before t (:class:`LaneChange`),
    so it changes into the ego's lane where it would relative to the template ego.
    """
    ego, p = placed.ego, placed.params
    fr = ego.frame
    s, v, t = p.get("s", 0.0), p.get("v", 0.0), p.get("t", 0.0)
    s_change = round(s + v * t, 4)  # [m] as the Scenic program lays a lane change out
    d_to = fr.lane_d(ego.ego_lane)
    route = (straight(fr, s, s_change, placed.lateral)
             + straight(fr, s_change + LANE_CHANGE_LENGTH, s_change + ROUTE_AHEAD, d_to))
    x, y = route[0]
    t_lay = max(0.0, t - LAY_OUT)
    change = LaneChange(ox=fr.ox, oy=fr.oy, ux=fr.ux, uy=fr.uy, d_to=d_to, lead=v * (t - t_lay),
                        length=LANE_CHANGE_LENGTH, ahead=ROUTE_AHEAD, ego_speed=ego.speed_event)
    return placed.actor_plan(x=x, y=y, heading=fr.heading, speed0=v, route=route, schedule=[(0.0, v, 0.0)],
                             trigger=offset_reached(ego, s + v * t_lay, v - ego.speed_event, t_lay),
                             lane_change=change)


__all__ = ["LAY_OUT", "ROUTE_AHEAD", "ahead_in_next_lane", "lane_change_plan", "overtakes", "s_at_event", "straight"]
