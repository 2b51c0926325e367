"""The registry of the motion primitives: every public module of this package defines ``SPEC``,
named like the module; they are imported on first use and looked up by name (:func:`get`,
:func:`find`) or by the actor they move (:func:`for_actor`). This module is private (its name
starts with ``_``), so the registry does not take it for a primitive."""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType

from regen.driving.primitives.base import Primitive
from regen.driving.world.specs import one_per_module
from regen.errors import GroundingError

PACKAGE = __name__.rpartition(".")[0]  # regen.driving.primitives
PATH = [str(Path(__file__).parent)]  # its __path__


@lru_cache(maxsize=1)
def registry() -> Mapping[str, Primitive]:
    """Every spec of this package by name (module order)."""
    specs: list[Primitive] = one_per_module(PACKAGE, PATH, "SPEC", "name", "primitive")  # type: ignore[assignment]
    return MappingProxyType({spec.name: spec for spec in specs})


@lru_cache(maxsize=1)
def state_only() -> Mapping[str, Primitive]:
    """The specs of the assets that only switch state (lights, sensors), by asset."""
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
    spec = state_only().get(asset)
    return spec if spec is not None else get(primitive)


def is_state_only(asset: str) -> bool:
    """Whether ``asset`` only switches state (a light or a sensor: no motion primitive)."""
    return asset in state_only()



__all__ = ["find", "for_actor", "get", "is_state_only", "registry", "state_only"]
