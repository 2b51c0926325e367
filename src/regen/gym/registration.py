"""The registration of the Gymnasium environments: every registered domain's envs
(:attr:`regen.contract.DomainBackend.gym_envs`) are registered when this module is imported, and
:func:`env_class` imports an env class by its class name on first use (the package's
``__getattr__``, so that ``from regen.gym import <EnvClass>`` works without importing every env)."""

from __future__ import annotations

import importlib

from regen import domains
from regen.errors import DependencyNotInstalled

try:
    from gymnasium.envs.registration import register, registry
except ImportError as exc:  # pragma: no cover - the extra is missing
    raise DependencyNotInstalled("gymnasium", "gym", "the regen Gymnasium environments") from exc


def domain_envs() -> dict[str, str]:
    """Env id -> entry point of every registered domain."""
    out: dict[str, str] = {}
    for name in domains.names():
        out.update(domains.backend_class(name).gym_envs)
    return out


def register_envs(envs: dict[str, str]) -> None:
    """Register ``envs`` (env id -> entry point) with Gymnasium; an id already there is kept."""
    for env_id, entry in envs.items():
        if env_id not in registry:
            register(id=env_id, entry_point=entry, nondeterministic=False)


ENVS = domain_envs()
ENV_IDS = sorted(ENVS)
register_envs(ENVS)


def env_class(name: str) -> type:
    """The env class named ``name`` (imported on first use); AttributeError, as a module's missing
    attribute, for any other name."""
    for entry in ENVS.values():
        module, _, cls = entry.partition(":")
        if cls == name:
            return getattr(importlib.import_module(module), cls)
    raise AttributeError(f"module 'regen.gym' has no attribute {name!r}")


__all__ = ["ENVS", "ENV_IDS", "domain_envs", "env_class", "register_envs"]
