"""The ego drives forward at 10 m/s in the outer lane of the straight road and changes into the
inner lane."""

from __future__ import annotations

from types import MappingProxyType

from regen.core.scenario import PredicateCall
from regen.driving.world.egos.base import E, EgoTemplate, line, straight_frame
from regen.driving.world.states import State, pred


class ChangeLane(EgoTemplate):
    rank = 3
    match_rank = 2
    keywords = (("lane",), ("chang", "switch", "merge"))
    example = "the ego vehicle changes lanes while driving forward"
    reaction_predicates = frozenset({"changing_lane"})
    reaction_class = "changes lane"
    never = MappingProxyType({"turning": "", "stopped": "", "braking": "", "brake_lights_on": "",
                              "accelerating": ""})

    def ego_states(self) -> tuple[State, list[State]]:
        return ("driving", [pred("moving", E, min_speed=5.0), pred("in_lane", E, lane=1)]), [
            ("changing_lane", [pred("changing_lane", E)]),
            ("in_new_lane", [pred("in_lane", E, lane=0), pred("moving", E, min_speed=5.0)])]

    def is_reaction_call(self, call: PredicateCall) -> bool:
        """Changing lane, or being in another lane than at the start."""
        return super().is_reaction_call(call) or (
            call.name == "in_lane" and int(float(call.params.get("lane", 0))) != self.ego_lane)


def _build() -> ChangeLane:
    fs = straight_frame()
    y0, y1 = fs.lane_d(0), fs.lane_d(1)
    v, te = 10.0, 6.0
    s_c = -150 + v * te
    return ChangeLane(
        "change_lane", "drives forward at 10 m/s in the outer lane and changes into the inner lane",
        "straight", tuple(line((-150, y1), (s_c, y1)) + line((s_c + 25, y0), (190, y0))), v,
        ((0.0, v, 0.0),), te, 16.0, fs, s_c, v, 1, False, -150 + v * 16.0, needs=("two_lanes",))


TEMPLATE = _build()
