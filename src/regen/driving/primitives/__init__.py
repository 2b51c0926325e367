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

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from types import MappingProxyType

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
from regen.driving.world.locations import LOCATIONS
from regen.driving.world.specs import one_per_module
from regen.errors import GroundingError


@lru_cache(maxsize=1)
def registry() -> Mapping[str, Primitive]:
    """Every spec of this package by name (module order)."""
    specs: list[Primitive] = one_per_module(__name__, __path__, "SPEC", "name", "primitive")  # type: ignore[assignment]
    return MappingProxyType({spec.name: spec for spec in specs})


@lru_cache(maxsize=1)
def _state_only() -> Mapping[str, Primitive]:
    return MappingProxyType({asset: spec for spec in registry().values() for asset in spec.only_for})


def get(name: str) -> Primitive:
    """The spec of the primitive ``name``; :class:`GroundingError` if there is none."""
    spec = registry().get(name)
    if spec is None:
        raise GroundingError(f"unknown motion primitive {name!r}; the driving primitives are "
                             f"{', '.join(registry())}")
    return spec


def find(name: str) -> Primitive | None:
    """The spec of the primitive ``name``, or None."""
    return registry().get(name)


def for_actor(asset: str, primitive: str) -> Primitive:
    """The spec that moves an actor: its asset's own for lights and sensors, else its primitive's."""
    spec = _state_only().get(asset)
    return spec if spec is not None else get(primitive)


def is_state_only(asset: str) -> bool:
    """Whether ``asset`` only switches state (a light or a sensor: no motion primitive)."""
    return asset in _state_only()


__all__ = ["LANE_CHANGE_LENGTH", "LOCATIONS", "SPEED_CLASSES", "VEHICLE_SPEEDS", "WALK_SPEEDS", "Placed",
           "Primitive", "RuleStates", "SpeedClasses", "find", "for_actor", "get", "is_state_only",
           "registry"]
