"""pull_over: a vehicle ahead in the ego's lane pulls over to the curb and stops there.

It drives ahead of the ego no faster than it, starts to pull over shortly before the ego's event
(keeping pace with the ego until then, as a lane change does:
:func:`regen.driving.primitives.shared.lanes.lane_change_plan`), moves out of the lane onto the curb
edge where parked cars stand, and brakes to a stop there: a car stopping for a passenger, a
breakdown, a vehicle making way.
"""

from __future__ import annotations

from dataclasses import replace

from regen.driving.primitives.base import Placed, RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.shared import lanes
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.locations import roadside_d
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan

PULL_TIME = 2.5  # [s] it takes to move over to the curb (across up to two lanes), whatever its speed
PULL_LENGTH = (12.0, 30.0)  # [m] least and most it travels meanwhile
BRAKE_SHARE = 0.7  # it brakes once this share of the move is done, so it stops straight at the curb
BRAKE_LEVEL = 0.4  # a firm, not an emergency, stop


def curb_d(ego: EgoTemplate, width: float) -> float:
    """Lateral offset [m] where it stops: the curb edge of the right road side, as a parked car."""
    return roadside_d(ego, "parked_car", width, "right")


def pull_length(v: float) -> float:
    """[m] travelled while it moves over at speed ``v`` [m/s]: :data:`PULL_TIME` of driving."""
    return min(PULL_LENGTH[1], max(PULL_LENGTH[0], v * PULL_TIME))


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    e, half = m.ego, m.half(a)
    s, v = m.start(a, speeds)
    lanes.s_at_event(m, a, s, v)
    m.at_least(a, "starts ahead of the ego in its lane", s, m.ego_s(0.0) + half + 6.0)
    m.at_most(a, f"drives no faster than the ego (v <= {e.speed_event:.0f} m/s)", v, e.speed_event)
    t = m.trigger(a)
    m.at_least(a, "pulls over 0.8 to 3 s before the ego's event", t, e.t_event - 3.0)
    m.at_most(a, "pulls over at least 0.8 s before the ego's event", t, e.t_event - 0.8)
    vt = m.product(a.name, "vt", v, t, 10 ** 7)
    ego_t = int(e.speed_event * DM) * t  # [dm * ds] the ego's travel until t, times 10
    # when it pulls over it is 6 to 30 m ahead of the ego: 10 (s + v t - ego_s(t)) in [60, 300] dm
    lo, hi = (int((m.ego_s(0.0) + half + d) * 100) for d in (6.0, 30.0))
    m.require(f"{a.name}: is 6 to 30 m ahead of the ego when it pulls over", 10 * s + vt - ego_t >= lo)
    m.require(f"{a.name}: is at most 30 m ahead of the ego when it pulls over", 10 * s + vt - ego_t <= hi)


def _plan(placed: Placed) -> ActorPlan:
    """The lane change of :func:`lanes.lane_change_plan`, to the curb, then a stop there."""
    plan = lanes.lane_change_plan(placed)
    fr, p = placed.ego.frame, placed.params
    d = curb_d(placed.ego, placed.actor.size[1])
    s, v, t = p.get("s", 0.0), p.get("v", 0.0), p.get("t", 0.0)
    s_change = round(s + v * t, 4)
    length = pull_length(v)
    plan.route = (lanes.straight(fr, s, s_change, placed.lateral)
                  + lanes.straight(fr, s_change + length, s_change + lanes.ROUTE_AHEAD, d))
    assert plan.lane_change is not None
    plan.lane_change = replace(plan.lane_change, d_to=d, length=length)
    brake = t + BRAKE_SHARE * length / max(v, 1.0)
    plan.schedule = [(0.0, v, 0.0), (round(brake, 4), 0.0, BRAKE_LEVEL)]
    plan.comment = f"pull_over from {placed.actor.location} to the curb"
    return plan


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    return RuleStates(initial=("ahead_in_lane", [pred("same_lane", a, e), pred("ahead_of", a, e), pred("moving", a)]),
                      cause=(("pulling_over", [pred("changing_lane", a), pred("ahead_of", a, e)]),),
                      final=("at_the_curb", [pred("stopped", a), pred("same_lane", a, e, negate=True)]))


SPEC = VehiclePrimitive(name="pull_over", starts=("ahead_same_lane",), leaves_line=True,
                        add_constraints=_constrain, build_plan=_plan, rule_states=_rule_states)
