"""The ego waits stationary on the straight road, then drives forward, accelerating to 10 m/s."""

from __future__ import annotations

from types import MappingProxyType

from regen.driving.world.egos.base import E, EgoTemplate, line, straight_frame
from regen.driving.world.states import State, pred


class DriveForward(EgoTemplate):
    rank = 2
    match_rank = 5
    keywords = (("driv", "go", "start", "accelerat", "forward", "move"),)
    example = "the ego drives forward from stationary"
    reaction_predicates = frozenset({"moving", "accelerating", "steady"})
    reaction_class = "drives off"
    never = MappingProxyType({"turning": "", "changing_lane": "", "braking": "", "brake_lights_on": ""})
    waits_at_start = True

    def ego_states(self) -> tuple[State, list[State]]:
        return ("waiting", [pred("stopped", E)]), [
            ("driving_off", [pred("moving", E, min_speed=2.0), pred("accelerating", E)])]


def _build() -> DriveForward:
    fs = straight_frame()
    y0 = fs.lane_d(0)
    t_go = 4.0
    return DriveForward(
        "drive_forward", "waits stationary, then drives forward, accelerating to 10 m/s",
        "straight", tuple(line((-120, y0), (190, y0))), 0.0,
        ((0.0, 0.0, 1.0), (t_go, 10.0, 0.0)), t_go, 16.0, fs, -120.0, 0.0, 0, False,
        -120.0 + 10.0 * (16.0 - t_go) - 9.0, junction_maps=("four_way",))


TEMPLATE = _build()
