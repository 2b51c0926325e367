"""The ego drives forward at 10 m/s on the straight road and stops abruptly (full brake)."""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.world.egos.base import (
    NOT_ON_STRAIGHT,
    EgoTemplate,
    speed_change_on_straight,
    stop_distance,
    stopping_states,
)
from regen.driving.world.states import State


class StopAbruptly(EgoTemplate):
    rank = 0
    match_rank = 4
    keywords = (("stop", "brake", "halt"),)
    example = "the ego brakes hard while driving"
    never = MappingProxyType({**NOT_ON_STRAIGHT, "in_junction": " and stops before any junction"})

    def ego_states(self) -> tuple[State, list[State]]:
        return stopping_states()


TEMPLATE = speed_change_on_straight(
    StopAbruptly, "stop_abruptly", "drives forward at 10 m/s and stops abruptly (full brake)", speed=10.0,
    to_speed=0.0, brake=1.0, stops=True, after_event=stop_distance(10.0))
