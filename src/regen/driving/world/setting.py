"""What a driving behavior and a driving scenario are set up with: the behavior's parameters
(``Behavior.params``: an ego template or a route) and the scenario's world settings
(``Scenario.world``: map, ego template, duration, step, seed, who grounded it), typed.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.base import Model
from regen.core.behavior import BehaviorParams
from regen.core.scenario import WorldSettings


class Waypoint(Model):
    x: float  # [m], map frame
    y: float  # [m], map frame
    speed: float | None = None  # target speed at this waypoint [m/s]


class DrivingParams(BehaviorParams):
    """A driving behavior's parameters: the ego template it follows (a route with speed profile,
    e.g. ``stop_abruptly``; default: the one its text describes), or an explicit route."""

    ego_template: str | None = Field(default=None, description="Id of an ego behavior template")
    route: list[Waypoint] | None = Field(default=None, description="Explicit ego route")


class DrivingWorld(WorldSettings):
    """``Scenario.world`` of a driving scenario. Keys are written in field order, unset ones
    (None) left out; keys of other writers are kept."""

    map: str | None = None  # generated map name (regen.driving.world.maps); simulation needs one
    ego_template: str | None = None  # id of the ego template the scenario was grounded with
    duration: float = 16.0  # [s] simulated
    dt: float = 0.1  # [s] simulation step
    seed: int = 0
    grounder: str | None = None  # 'model', 'model+rules' or 'rule-based'
    # model grounding: the parts the model and the rules wrote, the model, its calls
    model_parts: str | None = None
    rule_parts: str | None = None
    llm: str | None = None
    model_calls: str | None = None
    grounding_notes: str | None = None  # why the rules wrote parts of it, in words


__all__ = ["DrivingParams", "DrivingWorld", "Waypoint"]
