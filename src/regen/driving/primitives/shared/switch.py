"""What lights and sensors share: they only switch state, shortly before the ego's event."""

from __future__ import annotations

from typing import Any

from regen.driving.world.actors import ActorSpec
from regen.driving.world.placement import PlacementModel


def switch_time(m: PlacementModel, a: ActorSpec) -> Any:
    """The time ``t`` [s] at which the actor switches state: 0.2 to 2.5 s before the ego's event."""
    te = m.ego.t_event
    t = m.trigger(a)
    m.at_least(a, f"switches state 0.2 to 2.5 s before the ego's event (t={te:.1f} s)", t, te - 2.5)
    m.at_most(a, "switches state no later than 0.2 s before the ego's event", t, te - 0.2)
    return t


__all__ = ["switch_time"]
