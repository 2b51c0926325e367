"""The ego drives forward at 12 m/s on the straight road and slows down to 4 m/s."""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.world.egos.base import NOT_ON_STRAIGHT, E, EgoTemplate, speed_change_on_straight
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


# it ends 32 m past the event plus 4 m/s for all but the last 3 s after it
TEMPLATE = speed_change_on_straight(
    SlowDown, "slow_down", "drives forward at 12 m/s and slows down to 4 m/s", speed=12.0, to_speed=4.0,
    brake=0.35, stops=False, after_event=32 + 4.0 * (16.0 - 6.0 - 3.0))
