"""The ego's sensors (GNSS, camera): they ride on the ego and only switch their signal."""

from __future__ import annotations

import math

from regen.driving.primitives.base import Placed, Primitive, RuleStates, pred
from regen.driving.primitives.shared import switch
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import PlacementModel
from regen.driving.world.plan import ActorPlan
from regen.driving.world.triggers import approach

SENSOR_SIZE = 0.1  # [m] length, width and height of the marker a sensor gets in a trace


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    switch.switch_time(m, a)


def _plan(placed: Placed) -> ActorPlan:
    (ex, ey), (nx, ny) = placed.ego.route[0], placed.ego.route[1]
    a, ego = placed.actor, placed.ego
    # the signal degrades as the ego comes near where its event happens (a tunnel, a jammer)
    event = ego.frame.point(ego.s_event, ego.frame.lane_d(ego.ego_lane))
    return ActorPlan(name=a.name, asset=a.asset, kind="sensor", cls="", x=ex, y=ey,
                     heading=math.atan2(ny - ey, nx - ex), length=SENSOR_SIZE, width=SENSOR_SIZE,
                     height=SENSOR_SIZE, attach_to="ego", comment="sensor on the ego",
                     trigger=approach(ego, event, placed.params.get("t", 0.0)))


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a = r.name
    return RuleStates(initial=("nominal", [pred("signal_degraded", a, negate=True)]),
                      cause=(("degraded", [pred("signal_degraded", a), pred("perceived_error_above", a)]),))


SPEC = Primitive(
    name="onboard_sensor",
    users=frozenset({"sensors"}),
    only_for=frozenset({"gnss", "camera"}),
    starts=(),  # it has no place of its own
    speeds=None,
    moves=True,  # with the ego
    add_constraints=_constrain,
    build_plan=_plan,
    rule_states=_rule_states,
)
