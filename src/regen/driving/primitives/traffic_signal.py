"""The traffic light: it has no motion primitive, it only switches its light.

On a junction map it stands at the junction corner (as a stationary actor would); on a straight
road at a crossing just beyond where the ego stops or has its event.
"""

from __future__ import annotations

import math

from regen.driving.actors import ActorSpec, RoleChoice
from regen.driving.cpsat import PlacementModel
from regen.driving.ego import EgoTemplate
from regen.driving.maps import geometry
from regen.driving.plan import ActorPlan
from regen.driving.primitives import _switch, stationary
from regen.driving.primitives.base import Placed, Primitive, RuleStates, pred


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    t = _switch.switch_time(m, a)
    if a.properties.get("light_state") == "turns_red":
        m.at_least(a, "turns red after at least 2 s of yellow, so after t=2 s", t, 2.0)


def _plan(placed: Placed) -> ActorPlan:
    ego = placed.ego
    if geometry(ego.map).junction:
        return stationary.SPEC.build_plan(placed)
    s = (ego.s_end if ego.stops else ego.s_event) + 6.0
    x, y = ego.frame.point(s, ego.frame.sidewalk_d("right"))
    return placed.actor_plan(x=x, y=y, heading=ego.frame.heading + math.pi,
                             comment="traffic light at a crossing")


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a = r.name
    shown = r.properties.get("light_state", "turns_red")
    if shown == "turns_red":
        return RuleStates(initial=("green", [pred("light_is", a, value="green")]),
                          cause=("red", [pred("light_is", a, value="red")]))
    if shown == "red" and t.id == "drive_forward":
        return RuleStates(initial=("red", [pred("light_is", a, value="red")]),
                          cause=("green", [pred("light_is", a, value="green")]))
    return RuleStates(initial=(f"shows_{shown}", [pred("light_is", a, value=shown)]))


SPEC = Primitive(
    name="traffic_signal",
    users=frozenset({"traffic"}),
    only_for=frozenset({"traffic_light"}),
    starts=("junction_corner",),
    speeds=None,
    moves=False,
    add_constraints=_constrain,
    build_plan=_plan,
    rule_states=_rule_states,
)
