"""The registry of simulation domains: name -> backend class, imported on first use.

A domain is a package with a :class:`regen.contract.DomainBackend` subclass and one
:func:`register` call here (or in the user's code). Imports are lazy, so a missing optional
simulator is reported with its install command when the domain is used, not at import time;
this module imports nothing of the contract or of any domain, so every layer may ask it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from regen.errors import ConfigError

if TYPE_CHECKING:
    from regen.contract import DomainBackend


_REGISTRY: dict[str, str] = {}  # name -> 'package.module:Class'
_LOADED: dict[str, type[DomainBackend]] = {}  # entry point -> class, imported once


def register(name: str, entry_point: str | type[DomainBackend]) -> None:
    """Register a domain backend (a :class:`regen.contract.DomainBackend` subclass) as ``'package.module:Class'`` (imported on first use) or as
    the class itself."""
    if isinstance(entry_point, str):
        _REGISTRY[name] = entry_point
    else:
        _REGISTRY[name] = f"{entry_point.__module__}:{entry_point.__qualname__}"
        _LOADED[_REGISTRY[name]] = entry_point


def unregister(name: str) -> None:
    _REGISTRY.pop(name, None)


def names() -> list[str]:
    """The registered domain names, sorted."""
    return sorted(_REGISTRY)


def backend_class(name: str) -> type[DomainBackend]:
    """The backend class of domain ``name``; ConfigError naming the choices when unknown."""
    if name not in _REGISTRY:
        raise ConfigError(f"unknown domain {name!r}; choose one of: {', '.join(names())}")
    entry = _REGISTRY[name]
    if entry not in _LOADED:
        module, _, cls = entry.partition(":")
        _LOADED[entry] = getattr(importlib.import_module(module), cls)
    return _LOADED[entry]


def make(name: str) -> DomainBackend:
    """A backend instance of domain ``name``."""
    return backend_class(name)()


register("driving", "regen.driving.backend:DrivingBackend")
register("manipulation", "regen.manipulation.backend:ManipulationBackend")
