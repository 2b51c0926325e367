"""The ego turns right at the T-junction at 6 m/s (east-bound to south-bound), then stops
abruptly."""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

from regen.driving.world.egos.base import (
    JUNCTION_CX,
    EgoTemplate,
    arc,
    junction_frame,
    line,
    stop_distance,
    stopping_states,
)
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.driving.world.states import State, pred
from regen.errors import ConfigError


class StopAfterTurn(EgoTemplate):
    rank = 5
    match_rank = 1
    keywords = (("stop", "halt", "brake"), ("turn",))
    example = "Ego stops abruptly after turning right"
    never = MappingProxyType({"accelerating": ""})
    passes_junction = "after its turn the ego is past the junction"
    starts_elsewhere = "behind the ego: it starts on another road before its turn"

    def ego_states(self) -> tuple[State, list[State]]:
        return stopping_states()

    def prelude(self) -> list[State]:
        return [("turning", [pred("turning", "ego"), pred("moving", "ego", min_speed=2.0)])]

    def on_map(self, map_name: str) -> EgoTemplate:
        """The same turn on another junction map: only the frame's map changes."""
        if map_name == self.map:
            return self
        if map_name not in self.junction_maps:
            raise ConfigError(f"ego template {self.id!r} cannot run on map {map_name!r}")
        return replace(self, map=map_name, frame=junction_frame(map_name, "south"))


def _build() -> StopAfterTurn:
    ft = junction_frame("t_junction", "south")
    cx, r, w = JUNCTION_CX, JUNCTION_RADIUS, ft.lane_width
    yj = -w / 2
    x_entry = cx - r
    vt = 6.0
    rad = r - w / 2
    turn = arc((x_entry, -r), rad, math.pi / 2, 0.0)  # right turn: east-bound to south-bound
    route = line((x_entry - 50, yj), (x_entry, yj)) + turn[1:] + line((cx - w / 2, -r), (cx - w / 2, -r - 120))[1:]
    t_turn_end = (50 + rad * math.pi / 2) / vt
    te_t = t_turn_end + 2.5
    s_et = r + vt * (te_t - t_turn_end)
    return StopAfterTurn(
        "stop_after_turn", "turns right at the T-junction at 6 m/s, then stops abruptly",
        "t_junction", tuple(route), vt, ((0.0, vt, 0.0), (te_t, 0.0, 1.0)), te_t, te_t + 6.0, ft,
        s_et, vt, 0, True, s_et + stop_distance(vt), junction_maps=("four_way",), needs=("junction",))


TEMPLATE = _build()
