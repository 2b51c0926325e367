"""An OpenSCENARIO file as :func:`regen.driving.interop.xosc_read.read_xosc` reads it, as plain
data: its entities, where they start, their events with their actions and start conditions.

Imports: nothing of the project.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Condition:
    """One start condition. ``kind``: 'time', 'distance', 'ttc', 'speed' or 'offset'."""

    kind: str
    value: float
    rule: str  # 'lessThan', 'lessOrEqual', 'greaterThan', 'greaterOrEqual', 'equalTo'
    entity: str = ""  # the triggering entity (entity conditions)
    ref: str = ""  # the reference entity (offset)
    point: tuple[float, float] | None = None  # the position (distance, ttc)
    delay: float = 0.0  # [s] after the condition holds


@dataclass(frozen=True)
class Action:
    """One action. ``kind``: 'trajectory', 'speed', 'lane_change' (motion), 'signal' (a traffic
    signal of the map switches to ``state``) or 'state' (the actor's property ``key`` becomes
    ``state``: a door, a siren, hazard lights)."""

    kind: str
    # trajectory: (t [s], x [m], y [m], heading [rad]) vertices; relative: times from the event's start
    vertices: tuple[tuple[float, float, float, float], ...] = ()
    relative: bool = False
    target: float = 0.0  # speed [m/s], or lanes to the left (lane_change; negative: right)
    shape: str = "step"  # step, linear, cubic, sinusoidal
    dimension: str = "time"  # time [s], distance [m], rate [m/s^2]
    amount: float = 0.0  # the dynamics' value in its dimension
    signal: str = ""  # the signal's id in the map (signal)
    state: str = ""  # its new state (signal, state)
    key: str = ""  # the property it sets (state): door, siren, hazard_lights
    entity: str = ""  # whose property (state; empty: the event's actor)


@dataclass
class Event:
    actor: str
    name: str
    actions: list[Action]
    groups: list[list[Condition]]  # OR of ANDs; empty: starts with its act

    @property
    def at_start(self) -> bool:
        """Whether it starts with the scenario (no condition, or time >= 0)."""
        return not self.groups or any(
            all(c.kind == "time" and c.value <= 0.0 and c.rule in ("greaterOrEqual", "greaterThan") for c in g)
            for g in self.groups)


@dataclass
class EntityDecl:
    name: str
    kind: str  # 'vehicle', 'pedestrian', 'misc'
    category: str  # vehicleCategory, pedestrianCategory or miscObjectCategory
    role: str = ""  # Vehicle@role (OpenSCENARIO 1.2), e.g. 'ambulance', 'police'
    size: tuple[float, float, float] = (4.5, 1.8, 1.5)  # length, width, height [m]
    properties: dict[str, str] = field(default_factory=dict)


@dataclass
class ParsedScenario:
    path: Path
    description: str
    map_file: Path | None
    entities: dict[str, EntityDecl]
    start: dict[str, tuple[float, float, float]]  # name -> (x, y, heading)
    speed: dict[str, float]  # name -> start speed [m/s]
    events: list[Event]
    stop_time: float | None
    signals: dict[str, str] = field(default_factory=dict)  # signal id -> its state at the start
    states: dict[str, dict[str, str]] = field(default_factory=dict)  # entity -> property -> state at the start


__all__ = ["Action", "Condition", "EntityDecl", "Event", "ParsedScenario"]
