"""Motion primitives: one typed spec (:class:`~regen.driving.primitives.base.Primitive`) per
module of this package, collected into one registry.

Every public module here defines ``SPEC``, named like the module; the registry imports them all
on first use. Lights and sensors have no motion primitive; their specs (``only_for``) describe
the state switching of the assets they name, and :func:`for_actor` returns them for those assets
whatever primitive a role names.

To add a primitive: write ``<name>.py`` here with its ``SPEC`` and add
``tests/driving/primitives/test_<name>.py``; the conformance test
(``tests/driving/primitives/test_registry.py``) checks it against the rest of the toolkit.

Imports: ``world`` of this domain and the shared core (a primitive adds its parameters and
named constraints to the world's placement model; grounding reads the specs, never the reverse).
"""

from regen.driving.primitives.base import (
    LANE_CHANGE_LENGTH,
    SPEED_CLASSES,
    VEHICLE_SPEEDS,
    WALK_SPEEDS,
    Placed,
    Primitive,
    RuleStates,
    SpeedClasses,
)
from regen.driving.primitives.registry import (
    find,
    for_actor,
    get,
    is_state_only,
    registry,
    state_only,
)
from regen.driving.world.locations import LOCATIONS

__all__ = ["LANE_CHANGE_LENGTH", "LOCATIONS", "SPEED_CLASSES", "VEHICLE_SPEEDS", "WALK_SPEEDS", "Placed",
           "Primitive", "RuleStates", "SpeedClasses", "find", "for_actor", "get", "is_state_only",
           "registry", "state_only"]
