"""The ego drives forward at 10 m/s on the straight road and stops abruptly (full brake)."""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.world.egos.base import (
    NOT_ON_STRAIGHT,
    EgoTemplate,
    line,
    stop_distance,
    stopping_states,
    straight_frame,
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


def _build() -> StopAbruptly:
    fs = straight_frame()
    y0 = fs.lane_d(0)
    v, te = 10.0, 6.0
    s_e = -150 + v * te
    return StopAbruptly(
        "stop_abruptly", "drives forward at 10 m/s and stops abruptly (full brake)", "straight",
        tuple(line((-150, y0), (190, y0))), v, ((0.0, v, 0.0), (te, 0.0, 1.0)), te, 16.0, fs,
        s_e, v, 0, True, s_e + stop_distance(v), junction_maps=("four_way",))


TEMPLATE = _build()
