"""The ego drives straight into the four-way junction from the west arm and stops abruptly in it."""

from __future__ import annotations

from regen.driving.world.egos.base import (
    JUNCTION_CX,
    NOT_ON_STRAIGHT,
    EgoTemplate,
    junction_frame,
    line,
    stop_distance,
    stopping_states,
)
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.states import State


class StopInIntersection(EgoTemplate):
    rank = 4
    match_rank = 0
    keywords = (("stop", "halt", "brake"), ("intersection", "junction", "crossroad"))
    example = "the ego-vehicle stops abruptly in the intersection"
    never = NOT_ON_STRAIGHT

    def ego_states(self) -> tuple[State, list[State]]:
        return stopping_states(in_junction=True)


def _build() -> StopInIntersection:
    fj = junction_frame("four_way")
    cx, r, w = JUNCTION_CX, JUNCTION_RADIUS, fj.lane_width
    yj = -w / 2  # the east-bound lane of the west arm
    vj = 8.0
    x_entry = cx - r
    te_j = 60.0 / vj + 0.6  # just after it enters the junction
    s_ej = -r - 60 + vj * te_j
    return StopInIntersection(
        "stop_in_intersection", "drives straight into the four-way junction and stops abruptly in it",
        "four_way", tuple(line((x_entry - 60, yj), (cx + r + 100, yj))), vj,
        ((0.0, vj, 0.0), (te_j, 0.0, 1.0)), te_j, 14.0, fj, s_ej, vj, 0, True,
        s_ej + stop_distance(vj), needs=("junction",))


TEMPLATE = _build()
