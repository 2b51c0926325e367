"""The input of the whole pipeline: a robot behavior and its text."""

from __future__ import annotations

from pydantic import Field, field_validator

from regen.core.base import Model


class Waypoint(Model):
    x: float  # [m], map frame
    y: float  # [m], map frame
    speed: float | None = None  # target speed at this waypoint [m/s]


class Behavior(Model):
    """A robot behavior: its text, its domain, and what makes it executable.

    Driving behaviors name an ego template (a route with speed profile, e.g. ``stop_abruptly``)
    or give waypoints; manipulation behaviors name a reward function (e.g. ``open_door``).
    """

    text: str = Field(description="Natural-language description, e.g. 'the ego-vehicle stops abruptly'")
    domain: str = Field(min_length=1, description="A registered domain (regen.domains.names())")
    ego_template: str | None = Field(default=None, description="Driving: id of an ego behavior template")
    route: list[Waypoint] | None = Field(default=None, description="Driving: explicit ego route")
    reward: str | None = Field(default=None, description="Manipulation: id of a reward function")

    @field_validator("text")
    @classmethod
    def _text_not_empty(cls, v: str) -> str:
        v = " ".join(v.split())
        if not v:
            raise ValueError("the behavior text is empty: describe the robot behavior, e.g. "
                             "'the ego-vehicle stops abruptly while driving forward'")
        if len(v) > 2000:
            raise ValueError("the behavior text is longer than 2000 characters: shorten it")
        return v


def make_behavior(text: str, domain: str, **fields: object) -> Behavior:
    """A behavior from user input, checked against its domain (a registered one, whose backend
    accepts it) before any model call; ConfigError saying what to give otherwise."""
    from pydantic import ValidationError

    from regen import domains
    from regen.errors import ConfigError

    backend = domains.make(domain)  # an unknown domain names the choices
    try:
        behavior = Behavior(text=text, domain=domain, **fields)  # type: ignore[arg-type]
    except ValidationError as exc:
        msg = "; ".join(str(e["msg"]).removeprefix("Value error, ") for e in exc.errors())
        raise ConfigError(f"bad behavior: {msg}") from None
    backend.check_behavior(behavior)
    return behavior
