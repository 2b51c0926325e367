"""walk_along: a pedestrian walks along the sidewalk towards the ego."""

from __future__ import annotations

import math

from regen.driving.primitives.base import PedestrianPrimitive, Placed, RuleStates, pred
from regen.driving.primitives.shared import lanes
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.locations import LOCATIONS
from regen.driving.world.placement import PlacementModel
from regen.driving.world.plan import ActorPlan

WALK_LENGTH = 200.0  # [m] of sidewalk on its route


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    s, _ = m.start(a, speeds)
    m.at_least(a, "walks near the ego's event position", s, m.ego.s_event - 5.0)
    m.at_most(a, "starts within 35 m ahead of it", s, m.ego.s_event + 35.0)


def _plan(placed: Placed) -> ActorPlan:
    fr, p = placed.ego.frame, placed.params
    s = p.get("s", 0.0)
    route = lanes.straight(fr, s, s - WALK_LENGTH, fr.sidewalk_d(LOCATIONS[placed.actor.location].side))
    x, y = route[0]
    return placed.actor_plan(x=x, y=y, heading=fr.heading + math.pi, route=route,
                             schedule=[(0.0, p.get("v", 0.0), 0.0)])


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a = r.name
    return RuleStates(initial=("walking", [pred("moving", a, min_speed=0.3), pred("on_sidewalk", a)]),
                      cause=(("near_ego", [pred("moving", a, min_speed=0.3),
                                           pred("close_to", a, "ego", distance=20.0)]),))


SPEC = PedestrianPrimitive(name="walk_along", starts=("roadside_ahead", "roadside_opposite_ahead"),
                           add_constraints=_constrain, build_plan=_plan, rule_states=_rule_states)
