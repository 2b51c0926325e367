"""cut_in: a faster vehicle overtakes the ego in the next lane and cuts in close in front.

It keeps pace with the ego and cuts in as far ahead of it as in the template, whatever the ego's
speed (:func:`regen.driving.primitives.shared.lanes.lane_change_plan`).
"""

from __future__ import annotations

from regen.driving.primitives.base import RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.shared import lanes
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel


def _constrain(m: PlacementModel, a: ActorSpec, speeds: tuple[float, float]) -> None:
    e = m.ego
    s, v = m.start(a, speeds)
    lanes.s_at_event(m, a, s, v)
    lanes.overtakes(m, a, s, v)
    t = m.trigger(a)
    m.at_least(a, "cuts in 0.8 to 2.5 s before the ego's event", t, e.t_event - 2.5)
    m.at_most(a, "cuts in at least 0.8 s before the ego's event", t, e.t_event - 0.8)
    vt = m.product(a.name, "vt", v, t, 10 ** 7)
    # at t it must be ahead of the ego: 10 s + v t >= 10 (ego_s(0) + v_e t + half + 3)
    m.require(f"{a.name}: is ahead of the ego when it cuts in",
              10 * s + vt >= int((m.ego_s(0.0) + m.half(a) + 3.0) * 100) + int(e.speed_event * DM) * t)


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    # the cut-in is shown by the order: behind in the next lane, then in the ego's lane ahead
    return RuleStates(cause=(("overtaking", [pred("behind", a, e), pred("adjacent_lane", a, e), pred("moving", a)]),
                             ("cut_in", [pred("same_lane", a, e), pred("ahead_of", a, e), pred("moving", a)])))


SPEC = VehiclePrimitive(name="cut_in", starts=("behind_adjacent_lane",), leaves_line=True,
                        add_constraints=_constrain, build_plan=lanes.lane_change_plan,
                        rule_states=_rule_states)
