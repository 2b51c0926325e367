"""pass_through: an emergency vehicle with its siren on drives across the junction in front of
the ego, from the cross street, and the ego gives way (it stops in the junction, or waits).

It moves as a red-light runner does (:mod:`regen.driving.primitives.run_red_light`), a little
earlier relative to the ego's event: it is the cause the ego reacts to, its siren on throughout.
"""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.primitives.base import RuleStates, VehiclePrimitive, pred
from regen.driving.primitives.run_red_light import SPEC as RUN_RED_LIGHT
from regen.driving.primitives.shared import junction
from regen.driving.world.actors import RoleChoice
from regen.driving.world.egos import EgoTemplate


def _rule_states(r: RoleChoice, t: EgoTemplate) -> RuleStates:
    a = r.name
    return RuleStates(
        initial=("approaching_with_siren", [pred("siren_on", a), pred("moving", a),
                                            pred("in_junction", a, negate=True)]),
        cause=(("passing_through", [pred("siren_on", a), pred("in_junction", a), pred("moving", a)]),))


# in the junction from 1.2 s before to 0.8 s after the ego's event
SPEC = VehiclePrimitive(name="pass_through", starts=("junction_cross_street",), needs_junction=True,
                        add_constraints=junction.approach(early=1.2, late=0.8), build_plan=RUN_RED_LIGHT.build_plan,
                        rule_states=_rule_states, implies=MappingProxyType({"siren": "on"}))
