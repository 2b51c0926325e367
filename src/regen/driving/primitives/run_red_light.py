"""run_red_light: a vehicle on the cross street drives straight across the junction."""

from __future__ import annotations

import math

from regen.driving.primitives.base import Placed, VehiclePrimitive
from regen.driving.primitives.shared import junction
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.plan import ActorPlan


def _plan(placed: Placed) -> ActorPlan:
    start = junction.cross_street_start(placed)
    x0 = start[0]
    return junction.drive_through(placed, math.pi / 2,
                                   [start, (x0, 0.0), (x0, JUNCTION_RADIUS + junction.EXIT_LENGTH)])


# in the junction from 0.6 s before to 1 s after the ego's event
SPEC = VehiclePrimitive(name="run_red_light", starts=("junction_cross_street",), needs_junction=True,
                        add_constraints=junction.approach(early=0.6, late=1.0), build_plan=_plan,
                        rule_states=junction.rule_states)
