"""brake_ahead: the vehicle ahead of the ego in its lane brakes hard in front of it.

'The truck ahead stops abruptly', 'the car in front slams on its brakes': the lead drives in the
ego's lane, then brakes hard shortly before the ego reacts. Around an ego that stops, it comes to
rest 1.5 to 10 m ahead of where the ego stops; around one that slows down, it brakes down to the
speed the ego slows to. Its brake lights light up as it brakes (the
recorder reads them off its deceleration) unless the graph says they are broken. An ego that waits at its start has nobody braking ahead of it.
"""

from __future__ import annotations

from regen.driving.primitives.base import Placed, RuleStates, VehiclePrimitive
from regen.driving.primitives.shared import lanes, lead
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import PlacementModel
from regen.driving.world.plan import ActorPlan


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    s, v = m.start(a, speeds)
    e = m.ego
    if e.stops:
        lead.brakes_to_a_stop(m, a, s, v)
    elif e.speed_event > 0.0:
        lead.brakes_to_slow(m, a, s, v)
    else:  # nothing drives ahead of an ego that waits at its start
        m.at_most(a, "brakes in front of a moving ego (this ego waits at its start)", v, -1.0)


def _plan(placed: Placed) -> ActorPlan:
    fr, p, ego = placed.ego.frame, placed.params, placed.ego
    s, v, t = p.get("s", 0.0), p.get("v", 0.0), p.get("t", 0.0)
    route = lanes.straight(fr, s, s + lanes.ROUTE_AHEAD, placed.lateral)
    x, y = route[0]
    after, level = (0.0, 1.0) if ego.stops else (lead.slow_speed(ego), lead.SLOW_LEVEL)
    schedule = [(0.0, v, 0.0)] + ([(t, after, level)] if t > 0 else [])
    return placed.actor_plan(x=x, y=y, heading=fr.heading, speed0=v, route=route, schedule=schedule,
                             trigger=lead.brake_trigger(placed))


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    return lead.braking_states(r.name, t)


SPEC = VehiclePrimitive(name="brake_ahead", starts=("ahead_same_lane",), add_constraints=_constrain,
                        build_plan=_plan, rule_states=_rule_states)

