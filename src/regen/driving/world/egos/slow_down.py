"""The ego drives forward at 12 m/s on the straight road and slows down to 4 m/s."""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.world.egos.base import NOT_ON_STRAIGHT, E, EgoTemplate, line, straight_frame
from regen.driving.world.states import State, pred


class SlowDown(EgoTemplate):
    rank = 1
    match_rank = 3
    keywords = (("slow", "decelerat"),)
    example = "the ego slows down"
    reaction_predicates = frozenset({"braking", "slower_than", "brake_lights_on"})
    reaction_class = "slows down"
    never = MappingProxyType({**NOT_ON_STRAIGHT, "stopped": ""})

    def ego_states(self) -> tuple[State, list[State]]:
        return ("driving", [pred("moving", E, min_speed=8.0)]), [
            ("slowing", [pred("braking", E, min_decel=1.0)]),
            ("driving_slowly", [pred("moving", E, min_speed=1.0), pred("slower_than", E, max_speed=6.0)])]


def _build() -> SlowDown:
    fs = straight_frame()
    y0 = fs.lane_d(0)
    v, te = 12.0, 6.0
    s_e = -150 + v * te
    return SlowDown(
        "slow_down", "drives forward at 12 m/s and slows down to 4 m/s", "straight",
        tuple(line((-150, y0), (190, y0))), v, ((0.0, v, 0.0), (te, 4.0, 0.35)), te, 16.0, fs,
        s_e, v, 0, False, s_e + 32 + 4.0 * (16.0 - te - 3.0), junction_maps=("four_way",))


TEMPLATE = _build()
