"""What the primitives that drive through the junction share (turn_left, turn_right,
run_red_light): the approach window, the rule states and the route from an arm.

Junction maps (:mod:`regen.driving.world.maps`) have their centre at ``(JUNCTION_CX, 0)``; the ego
comes from the west arm. The cross street is the south arm (north-bound lane at
``x = JUNCTION_CX + w/2``), the oncoming arm the east one (west-bound lane at ``y = w/2``).
"""

from __future__ import annotations

from regen.driving.primitives.base import Constrain, Placed, RuleStates, pred
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import JUNCTION_CX, EgoTemplate
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.placement import DM, PlacementModel
from regen.driving.world.plan import ActorPlan, Point

EXIT_LENGTH = 150.0  # [m] a route runs this far past the junction


def approach(*, early: float, late: float) -> Constrain:
    """Constraints of an actor that enters the junction no earlier than ``early`` [s] before
    and no later than ``late`` [s] after the ego's event, from ``d0`` [m] before its edge."""

    def add(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
        _, v = m.start(a, speeds)
        d0 = m.int(a.name, "d0", 2.0, 140.0)
        te = m.ego.t_event
        # the time to reach the junction edge is d0 / v: compare d0 with v times the window ends
        m.require(f"{a.name}: enters the junction no earlier than {early:.1f} s before the ego's event",
                  d0 * 10 >= v * int((te - early) * DM))
        m.require(f"{a.name}: enters the junction no later than {late:+.1f} s after the ego's event",
                  d0 * 10 <= v * int((te + late) * DM))

    return add


def _through(r: RoleChoice, *, turns: bool) -> RuleStates:
    a = r.name
    inside = [pred("in_junction", a), pred("moving", a)] + ([pred("turning", a)] if turns else [])
    return RuleStates(
        initial=("approaching_junction", [pred("moving", a), pred("in_junction", a, negate=True)]),
        cause=(("in_junction", inside),))


def rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    """Approaching, then driving straight through the junction (run_red_light)."""
    return _through(r, turns=False)


def turning_rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    """Approaching, then turning in the junction (turn_left, turn_right)."""
    return _through(r, turns=True)


def cross_street_start(placed: Placed) -> Point:
    """Start [m] on the cross street's north-bound lane, ``d0`` before the junction."""
    return (JUNCTION_CX + placed.ego.frame.lane_width / 2, -JUNCTION_RADIUS - placed.params.get("d0", 0.0))


def oncoming_start(placed: Placed) -> Point:
    """Start [m] on the oncoming arm's west-bound lane, ``d0`` before the junction."""
    return (JUNCTION_CX + JUNCTION_RADIUS + placed.params.get("d0", 0.0), placed.ego.frame.lane_width / 2)


def drive_through(placed: Placed, heading: float, route: list[Point]) -> ActorPlan:
    """The plan of an actor that drives ``route`` (its start first) at its solved speed,
    starting with ``heading`` [rad]."""
    v = placed.params.get("v", 0.0)
    x, y = route[0]
    return placed.actor_plan(x=x, y=y, heading=heading, speed0=v, route=route, schedule=[(0.0, v, 0.0)])


__all__ = ["EXIT_LENGTH", "approach", "cross_street_start", "drive_through", "oncoming_start", "rule_states",
           "turning_rule_states"]
