"""Gymnasium environments over generated scenarios, one or more per domain.

Importing this package registers the envs every registered domain declares
(:attr:`regen.contract.DomainBackend.gym_envs`), so ``import regen.gym`` then
``gymnasium.make("regen/Driving-v0", runs=["runs/demo"])`` or
``gymnasium.make("regen/Manipulation-v0", runs=["runs/door"])`` works; without importing it,
``gymnasium.make("regen.gym:regen/Driving-v0", runs=[...])`` imports it on the fly (Gymnasium 1.x
loads no plugins by entry point). Needs the ``gym`` extra: ``pip install -e '.[gym]'`` in the checkout.
Env classes are imported on first use; ``from regen.gym import <EnvClass>`` imports one by its
class name.
"""

# env_class is the module's attribute hook (PEP 562): env classes are imported on first use
from regen.gym.registration import ENV_IDS, ENVS
from regen.gym.registration import env_class as __getattr__  # noqa: F401

__all__ = ["ENVS", "ENV_IDS"]
