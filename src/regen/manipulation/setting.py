"""What a manipulation behavior is set up with: its parameters (``Behavior.params``: its reward
function), typed.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.behavior import BehaviorParams


class ManipulationParams(BehaviorParams):
    """A manipulation behavior's parameters: the reward function (a task of
    :mod:`regen.manipulation.behaviors`, e.g. ``open_door``; default: the one its text describes)."""

    reward: str | None = Field(default=None, description="Id of a reward function")


__all__ = ["ManipulationParams"]
