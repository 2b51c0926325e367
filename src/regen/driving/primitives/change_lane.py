"""change_lane: a slower vehicle ahead in the next lane changes into the ego's lane.

It keeps pace with the ego and changes lanes as far ahead of it as in the template, whatever the
ego's speed (:func:`regen.driving.primitives.shared.lanes.lane_change_plan`).
"""

from __future__ import annotations

from regen.driving.primitives.base import RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.shared import lanes
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import PlacementModel


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    e = m.ego
    s, v = m.start(a, speeds)
    lanes.ahead_in_next_lane(m, a, lanes.s_at_event(m, a, s, v))
    t = m.trigger(a)
    m.at_least(a, "changes lane 1 to 3 s before the ego's event", t, e.t_event - 3.0)
    m.at_most(a, "changes lane at least 1 s before the ego's event", t, e.t_event - 1.0)
    m.at_most(a, f"is slower than the ego (v <= {e.speed_event - 2:.0f} m/s)", v, e.speed_event - 2.0)
    m.at_least(a, "starts ahead of the ego", s, m.ego_s(0.0) + m.half(a) + 5.0)


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    # the lane change is shown by the order: in the next lane ahead, then in the ego's lane ahead
    return RuleStates(cause=(("ahead_in_next_lane", [pred("ahead_of", a, e), pred("adjacent_lane", a, e),
                                                     pred("moving", a)]),
                             ("in_ego_lane", [pred("in_front", a, e, distance=40.0), pred("moving", a)])))


SPEC = VehiclePrimitive(name="change_lane", starts=("ahead_adjacent_lane",), leaves_line=True,
                        add_constraints=_constrain, build_plan=lanes.lane_change_plan,
                        rule_states=_rule_states)
