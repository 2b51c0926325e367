"""What a driving behavior and a driving scenario are set up with: the behavior's parameters
(``Behavior.params``: an ego template or a route) and the scenario's world settings
(``Scenario.world``: map, ego template, duration, step, seed, who grounded it), typed.
"""

from __future__ import annotations

from pydantic import Field

from regen.core.base import Model
from regen.core.behavior import BehaviorParams
from regen.core.scenario import AbstractState, WorldSettings


class Waypoint(Model):
    x: float  # [m], map frame
    y: float  # [m], map frame
    speed: float | None = None  # target speed at this waypoint [m/s]


class RecordedEgo(Model):
    """A recorded ego trajectory as the behavior (``regen generate --ego-trajectory``): what was
    detected in it and its samples in map coordinates, one per simulation step; the ego replays
    them exactly (:mod:`regen.driving.world.replay`)."""

    source: str  # the file's name, for the report
    frame: str  # 'ego_start' (placed on the map by the fit) or 'map' (given in map coordinates)
    map: str  # the generated map it runs on
    detected: str  # the behavior class (regen.driving.world.recorded.CLASSES)
    event_time: float  # [s] from the first sample: when the reaction starts
    placement: str  # how the path was put on the map, in words
    evidence: list[str] = Field(default_factory=list)  # what the detection saw
    dt: float  # [s] between samples
    # (x [m], y [m], heading [rad from +x], speed [m/s]) at t = k * dt
    samples: list[tuple[float, float, float, float]]


class ImportedActor(Model):
    """An actor of an imported OpenSCENARIO storyboard (``regen import``): its motion replayed
    exactly, one pose per simulation step, and the cause event that a condition on the ego
    starts (:mod:`regen.driving.interop.importing`)."""

    name: str  # the entity's name in the scenario
    source: str  # its ScenarioObject name in the file
    asset: str  # its asset in the driving database
    kind: str = "agent"  # the scenario entity's kind ('agent' or 'object')
    properties: dict[str, str] = Field(default_factory=dict)
    # (x [m], y [m], heading [rad from +x], speed [m/s]) at t = k * dt, from the events that start
    # with the scenario (what it does while its cause waits)
    before: list[tuple[float, float, float, float]]
    # after its cause event starts, at t_fire + k * dt: poses in map coordinates (a trajectory)
    # or, with ``relative``, (ahead [m], left [m], turn [rad], speed) from where it was then
    after: list[tuple[float, float, float, float]] = Field(default_factory=list)
    relative: bool = False
    # property -> [(t_from [s], value)] on the trigger's clock (a traffic light's state changes)
    states: dict[str, list[tuple[float, str]]] = Field(default_factory=dict)
    trigger: tuple | None = None  # regen.driving.world.triggers.Spec of the cause event, or None
    event: str = ""  # the cause event's name in the file
    condition: str = ""  # what starts it, in words
    action: str = ""  # what it does then, in words
    cause: AbstractState | None = None  # the state its cause event shows (the FSM's cause stage)


class ImportedStoryboard(Model):
    """What ``regen import`` read: the file, its map, and the actors it replays."""

    source: str  # the .xosc file's name
    map: str  # the generated map it runs on
    dt: float
    duration: float  # [s] the file's stop time
    actors: list[ImportedActor] = Field(default_factory=list)
    notes: list[str] = Field(default_factory=list)  # what was approximated, in words


class DrivingParams(BehaviorParams):
    """A driving behavior's parameters: the ego template it follows (a route with speed profile,
    e.g. ``stop_abruptly``; default: the one its text describes), an explicit route, or a
    recorded trajectory that the ego replays (its template is the detected class's)."""

    ego_template: str | None = Field(default=None, description="Id of an ego behavior template")
    route: list[Waypoint] | None = Field(default=None, description="Explicit ego route")
    recorded: RecordedEgo | None = Field(default=None, description="A recorded ego trajectory to replay")
    imported: ImportedStoryboard | None = Field(default=None, description="Actors of an imported OpenSCENARIO file")


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


__all__ = ["DrivingParams", "DrivingWorld", "ImportedActor", "ImportedStoryboard", "RecordedEgo", "Waypoint"]
