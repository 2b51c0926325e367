"""The traffic light: it has no motion primitive, it only switches its light.

On a junction map it stands at the junction corner (as a stationary actor would); on a straight
road at a crossing just beyond where the ego stops or has its event.
"""

from __future__ import annotations

import math

from regen.driving.primitives import stationary
from regen.driving.primitives.base import Placed, Primitive, RuleStates, pred
from regen.driving.primitives.shared import switch
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.maps import geometry
from regen.driving.world.placement import PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.properties import YELLOW_TIME
from regen.driving.world.triggers import approach

MIN_GREEN = 0.5  # [s] a light that turns red shows green at least this long first


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    t = switch.switch_time(m, a)
    if a.properties.get("light_state") == "turns_red":
        # green first long enough to be seen, else the turning is not shown
        t_min = MIN_GREEN + YELLOW_TIME
        m.at_least(a, f"turns red after {MIN_GREEN:g} s of green and {YELLOW_TIME:g} s of yellow, so after "
                   f"t={t_min:g} s", t, t_min)


def _plan(placed: Placed) -> ActorPlan:
    ego = placed.ego
    if geometry(ego.map).junction:
        plan = stationary.SPEC.build_plan(placed)
    else:
        s = (ego.s_end if ego.stops else ego.s_event) + 6.0
        x, y = ego.frame.point(s, ego.frame.sidewalk_d("right"))
        plan = placed.actor_plan(x=x, y=y, heading=ego.frame.heading + math.pi,
                                 comment="traffic light at a crossing")
    # it switches as the ego comes near it (for an ego that waits at it: at its solved time); a
    # light that turns red starts its yellow then, so it never stays yellow for a slow ego
    t = placed.params.get("t", 0.0)
    if placed.actor.properties.get("light_state") == "turns_red":
        t = max(0.0, t - YELLOW_TIME)
    plan.trigger = approach(ego, (plan.x, plan.y), t)
    return plan


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a = r.name
    shown = r.properties.get("light_state", "turns_red")
    # a light that switches shows it by the order of its two colors
    if shown == "turns_red":
        return RuleStates(cause=(("green", [pred("light_is", a, value="green")]),
                                 ("red", [pred("light_is", a, value="red")])))
    if shown == "red" and t.waits_at_start:
        return RuleStates(cause=(("red", [pred("light_is", a, value="red")]),
                                 ("green", [pred("light_is", a, value="green")])))
    return RuleStates(cause=((f"shows_{shown}", [pred("light_is", a, value=shown)]),))


SPEC = Primitive(
    name="traffic_signal",
    users=frozenset({"traffic"}),
    only_for=frozenset({"traffic_light"}),
    starts=("junction_corner", "roadside_ahead"),  # (on a straight road: at a crossing at the road side)
    speeds=None,
    moves=False,
    add_constraints=_constrain,
    build_plan=_plan,
    rule_states=_rule_states,
)
