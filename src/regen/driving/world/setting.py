"""What a driving behavior is set up with: its parameters (``Behavior.params``: an ego template
or a route), typed.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.base import Model
from regen.core.behavior import BehaviorParams


class Waypoint(Model):
    x: float  # [m], map frame
    y: float  # [m], map frame
    speed: float | None = None  # target speed at this waypoint [m/s]


class DrivingParams(BehaviorParams):
    """A driving behavior's parameters: the ego template it follows (a route with speed profile,
    e.g. ``stop_abruptly``; default: the one its text describes), or an explicit route."""

    ego_template: str | None = Field(default=None, description="Id of an ego behavior template")
    route: list[Waypoint] | None = Field(default=None, description="Explicit ego route")


__all__ = ["DrivingParams", "Waypoint"]
