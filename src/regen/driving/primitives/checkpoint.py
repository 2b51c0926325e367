"""checkpoint: a police vehicle stands in the ego's lane ahead with its siren and lights on (a
checkpoint or a road closure); the ego stops before it, or slows down past it.

It stands where a stationary object in the ego's path stands
(:mod:`regen.driving.primitives.stationary`), its lights on from the start.
"""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.primitives.base import Primitive, RuleStates, pred
from regen.driving.primitives.stationary import SPEC as STATIONARY
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a, e = r.name, "ego"
    return RuleStates(cause=(("checkpoint_ahead", [pred("stopped", a), pred("siren_on", a),
                                                   pred("same_lane", a, e), pred("ahead_of", a, e)]),),
                      final=("still_ahead", [pred("ahead_of", a, e)]))


SPEC = Primitive(name="checkpoint", users=frozenset({"vehicles"}), starts=("ahead_same_lane",), speeds=None,
                 moves=False, add_constraints=STATIONARY.add_constraints, build_plan=STATIONARY.build_plan,
                 rule_states=_rule_states, implies=MappingProxyType({"siren": "on"}))
