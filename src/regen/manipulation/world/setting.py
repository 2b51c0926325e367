"""What a manipulation behavior and a manipulation scenario are set up with: the behavior's
parameters (``Behavior.params``: its reward function) and the scenario's world settings
(``Scenario.world``: the task, the time cap, the seed, the simulator), typed.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.behavior import BehaviorParams
from regen.core.scenario import WorldSettings


class ManipulationParams(BehaviorParams):
    """A manipulation behavior's parameters: the reward function (a task of
    :mod:`regen.manipulation.world.tasks`, e.g. ``open_door``; default: the one its text describes)."""

    reward: str | None = Field(default=None, description="Id of a reward function")


class ManipulationWorld(WorldSettings):
    """``Scenario.world`` of a manipulation scenario. Keys are written in field order, unset ones
    (None) left out; keys of other writers are kept."""

    behavior: str = ""  # the task's id (regen.manipulation.world.tasks); empty: none named
    duration: float = 12.0  # [s] simulated time cap of one rollout
    seed: int = 0
    simulator: str | None = None  # 'pybullet'


__all__ = ["ManipulationParams", "ManipulationWorld"]
