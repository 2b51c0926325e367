"""Gymnasium environments over generated scenarios, one or more per domain.

Importing this package registers the envs every registered domain declares
(:attr:`regen.contract.DomainBackend.gym_envs`), so ``import regen.gym`` then
``gymnasium.make("regen/Driving-v0", runs=["runs/demo"])`` or
``gymnasium.make("regen/Manipulation-v0", runs=["runs/door"])`` works; without importing it,
``gymnasium.make("regen.gym:regen/Driving-v0", runs=[...])`` imports it on the fly (Gymnasium 1.x
loads no plugins by entry point). Needs the ``gym`` extra: ``pip install 'regen-sim[gym]'``.
Env classes are imported on first use; ``from regen.gym import <EnvClass>`` imports one by its
class name.
"""

from __future__ import annotations

import importlib

from regen import domains
from regen.errors import DependencyNotInstalled

try:
    from gymnasium.envs.registration import register, registry
except ImportError as exc:  # pragma: no cover - the extra is missing
    raise DependencyNotInstalled("gymnasium", "gym", "the regen Gymnasium environments") from exc


def _envs() -> dict[str, str]:
    """Env id -> entry point of every registered domain."""
    out: dict[str, str] = {}
    for name in domains.names():
        out.update(domains.backend_class(name).gym_envs)
    return out


ENVS = _envs()
ENV_IDS = sorted(ENVS)

for _id, _entry in ENVS.items():
    if _id not in registry:
        register(id=_id, entry_point=_entry, nondeterministic=False)


def __getattr__(name: str):
    for entry in ENVS.values():
        module, _, cls = entry.partition(":")
        if cls == name:
            return getattr(importlib.import_module(module), cls)
    raise AttributeError(f"module 'regen.gym' has no attribute {name!r}")


__all__ = ["ENVS", "ENV_IDS"]
