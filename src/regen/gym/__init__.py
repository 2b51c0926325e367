"""Gymnasium environments over generated scenarios: ``regen/Driving-v0``.

Importing this package registers the env, so ``import regen.gym`` then
``gymnasium.make("regen/Driving-v0", runs=["runs/demo"])`` works; without importing it,
``gymnasium.make("regen.gym:regen/Driving-v0", runs=[...])`` imports it on the fly (Gymnasium 1.x
loads no plugins by entry point). Needs the ``gym`` extra: ``pip install 'regen-sim[gym]'``.
The env class (:class:`~regen.driving.gym.env.DrivingEnv`) is imported on first use.
"""

from __future__ import annotations

from regen.errors import DependencyNotInstalled

try:
    from gymnasium.envs.registration import register, registry
except ImportError as exc:  # pragma: no cover - the extra is missing
    raise DependencyNotInstalled("gymnasium", "gym", "the regen/Driving-v0 environment") from exc

DRIVING_ID = "regen/Driving-v0"

if DRIVING_ID not in registry:
    register(id=DRIVING_ID, entry_point="regen.driving.gym.env:DrivingEnv", nondeterministic=False)


def __getattr__(name: str):
    if name == "DrivingEnv":
        from regen.driving.gym.env import DrivingEnv

        return DrivingEnv
    raise AttributeError(f"module 'regen.gym' has no attribute {name!r}")


__all__ = ["DRIVING_ID", "DrivingEnv"]
