"""turn_right: a vehicle on the cross street turns right into the ego's direction."""

from __future__ import annotations

import math

from regen.driving.primitives.base import Placed, VehiclePrimitive
from regen.driving.primitives.shared import junction
from regen.driving.world.egos import JUNCTION_CX, arc
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.plan import ActorPlan


def _plan(placed: Placed) -> ActorPlan:
    cx, r, w = JUNCTION_CX, JUNCTION_RADIUS, placed.ego.frame.lane_width
    turn = arc((cx + r, -r), r - w / 2, math.pi, math.pi / 2)  # into the east arm, east-bound
    route = [junction.cross_street_start(placed)] + turn + [(cx + r + junction.EXIT_LENGTH, -w / 2)]
    return junction.drive_through(placed, math.pi / 2, route)


# in the junction from 2 s to 0.2 s before the ego's event
SPEC = VehiclePrimitive(name="turn_right", starts=("junction_cross_street",), leaves_line=True, turns=True,
                        needs_junction=True, add_constraints=junction.approach(early=2.0, late=-0.2),
                        build_plan=_plan, rule_states=junction.turning_rule_states)
