"""wait_at_curb: a person stands at the curb ahead, waiting or hailing (for a taxi, a bus, to
cross); the ego slows down or stops for them.

They stand where a stationary road user at the road side stands
(:mod:`regen.driving.primitives.stationary`); the cause is that they wait at the curb, close
ahead of the ego.
"""

from __future__ import annotations

from regen.driving.primitives.base import PedestrianPrimitive, RuleStates, pred
from regen.driving.primitives.stationary import SPEC as STATIONARY
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    return RuleStates(cause=(("waiting_at_curb", [pred("stopped", a), pred("on_sidewalk", a),
                                                  pred("ahead_of", a, e), pred("close_to", a, e, distance=40.0)]),))


SPEC = PedestrianPrimitive(name="wait_at_curb", starts=("roadside_ahead", "roadside_opposite_ahead"), moves=False, speeds=None,
                           scenic_behavior="", xosc_trajectory=False, add_constraints=STATIONARY.add_constraints,
                           build_plan=STATIONARY.build_plan, rule_states=_rule_states)
