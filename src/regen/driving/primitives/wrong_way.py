"""wrong_way: a vehicle drives against the traffic in the ego's lane, towards the ego; both
brake, and it comes to rest facing the ego ahead of where the ego stops.

Only an ego that stops can meet it (a car coming at it in its own lane leaves no other safe
reaction); with any other ego template the placement is infeasible and says so.
"""

from __future__ import annotations

import math

from regen.driving.primitives.base import Placed, RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.shared import lanes
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import approach


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    e, half, te = m.ego, m.half(a), m.ego.t_event
    s, v = m.start(a, speeds)
    if not e.stops:  # a constraint that cannot hold, named: the conflict says why
        m.require(f"{a.name}: meets only an ego that stops (it drives at the ego in the ego's own lane)", v < 0)
        return
    s_te = m.m.NewIntVar(-100000, 100000, f"{a.name}.s_te")  # [dm] where it is at the ego's event
    m.m.Add(10 * s_te - 10 * s + v * int(round(te * DM)) >= 0)
    m.m.Add(10 * s_te - 10 * s + v * int(round(te * DM)) <= 9)
    m.at_most(a, "is within 50 m ahead of the ego at its event", s_te, e.s_event + 50.0)
    t = m.trigger(a)
    m.at_least(a, "brakes 0.3 to 1.5 s after the ego's event", t, te + 0.3)
    m.at_most(a, "brakes at most 1.5 s after the ego's event", t, te + 1.5)
    vt = m.product(a.name, "vt", v, t, 10 ** 7)
    sq = m.product(a.name, "v2", v, v, 10 ** 6)
    # where it comes to rest [dm], driving towards -s: s - v t - v^2 / (2 * 6.8 m/s^2) - 0.1 v
    stop = m.m.NewIntVar(-100000, 100000, f"{a.name}.stop")
    m.m.Add(1360 * stop >= 1360 * s - 136 * vt - 10 * sq - 140 * v - 1360)
    m.m.Add(1360 * stop <= 1360 * s - 136 * vt - 10 * sq - 140 * v + 1360)
    m.at_least(a, "comes to rest 3 to 15 m ahead of where the ego stops", stop, e.s_end + half + 3.0)
    m.at_most(a, "comes to rest at most 15 m ahead of the ego's stop", stop, e.s_end + half + 15.0)


def _plan(placed: Placed) -> ActorPlan:
    ego, p = placed.ego, placed.params
    fr = ego.frame
    s, v, t = p.get("s", 0.0), p.get("v", 0.0), p.get("t", 0.0)
    route = lanes.straight(fr, s, s - lanes.ROUTE_AHEAD, placed.lateral)
    x, y = route[0]
    s_brake = s - v * t
    return placed.actor_plan(x=x, y=y, heading=fr.heading + math.pi, speed0=v, route=route,
                             schedule=[(0.0, v, 0.0), (t, 0.0, 1.0)],
                             trigger=approach(ego, fr.point(s_brake, placed.lateral), t),
                             comment=f"wrong_way from {placed.actor.location}, towards the ego")


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    return RuleStates(
        cause=(("coming_at_the_ego", [pred("same_lane", a, e), pred("ahead_of", a, e), pred("moving", a),
                                      pred("close_to", a, e, distance=60.0)]),),
        final=("stopped_facing_the_ego", [pred("stopped", a), pred("ahead_of", a, e)]))


SPEC = VehiclePrimitive(name="wrong_way", starts=("ahead_same_lane",), add_constraints=_constrain,
                        build_plan=_plan, rule_states=_rule_states)
