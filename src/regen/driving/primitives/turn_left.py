"""turn_left: an oncoming vehicle turns left across the ego's path into the south arm."""

from __future__ import annotations

import math

from regen.driving.primitives.base import Placed, VehiclePrimitive
from regen.driving.primitives.shared import junction
from regen.driving.world.egos import JUNCTION_CX, arc
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.plan import ActorPlan


def _plan(placed: Placed) -> ActorPlan:
    cx, r, w = JUNCTION_CX, JUNCTION_RADIUS, placed.ego.frame.lane_width
    turn = arc((cx + r, -r), r + w / 2, math.pi / 2, math.pi)
    route = [junction.oncoming_start(placed)] + turn + [(cx - w / 2, -r - junction.EXIT_LENGTH)]
    return junction.drive_through(placed, math.pi, route)


# in the junction from 1 s before to 0.5 s after the ego's event
SPEC = VehiclePrimitive(name="turn_left", starts=("junction_oncoming",), leaves_line=True, turns=True,
                        needs_junction=True, add_constraints=junction.approach(early=1.0, late=0.5),
                        build_plan=_plan, rule_states=junction.turning_rule_states)
