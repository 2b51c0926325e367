"""What a simulation recorded: per actor, per step, pose, speed and property states.

Columnar (one list per quantity) so that long traces stay small in JSON and predicates can be
evaluated over all steps at once with numpy.
"""

from __future__ import annotations

from pydantic import Field, model_validator

from regen.core.base import Model

StateValue = str | float | bool | None


class ActorTrack(Model):
    asset: str
    kind: str = "agent"  # agent, object, ego, robot
    length: float = 0.0  # [m] footprint along heading
    width: float = 0.0  # [m]
    height: float = 0.0  # [m]
    x: list[float]  # [m]
    y: list[float]  # [m]
    z: list[float] = Field(default_factory=list)  # [m]; empty for planar simulators
    heading: list[float] = Field(default_factory=list)  # [rad], counter-clockwise from +x
    speed: list[float] = Field(default_factory=list)  # [m/s]
    states: dict[str, list[StateValue]] = Field(default_factory=dict)  # e.g. 'siren': ['on', ...]


class Trace(Model):
    dt: float  # [s] per step
    times: list[float]  # [s]
    actors: dict[str, ActorTrack]
    meta: dict[str, str | float | int | bool] = Field(default_factory=dict)  # simulator, map, ...

    @model_validator(mode="after")
    def _lengths(self) -> Trace:
        n = len(self.times)
        for name, a in self.actors.items():
            for field in ("x", "y", "z", "heading", "speed"):
                seq = getattr(a, field)
                if seq and len(seq) != n:
                    raise ValueError(f"actor {name!r}: {field} has {len(seq)} values for {n} steps")
            for key, seq in a.states.items():
                if len(seq) != n:
                    raise ValueError(f"actor {name!r}: state {key!r} has {len(seq)} values for {n} steps")
        return self

    @property
    def steps(self) -> int:
        return len(self.times)
