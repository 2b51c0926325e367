"""Start locations, relative to the ego: what each means, what map it needs, where it lies.

Grounding chooses one start location per actor from :data:`LOCATIONS` (the model from the
ones its primitive supports, see :mod:`regen.driving.primitives`); free text from the graph's
property nodes is mapped onto them by :func:`location_from_text`.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from regen.driving.world.actors import PARKED_ASSETS
from regen.driving.world.egos import EgoTemplate

Side = Literal["right", "left"]


def roadside_d(ego: EgoTemplate, asset: str, width: float, side: Side) -> float:
    """Lateral offset [m] of something of ``width`` [m] standing at the road side: on the
    sidewalk, except a parked car, which stands at the curb edge of the outermost lane (half on
    the curb on a one-lane road, so the ego can pass)."""
    fr = ego.frame
    if asset not in PARKED_ASSETS:
        return fr.sidewalk_d(side)
    edge = fr.lanes_same_direction * fr.lane_width
    if side == "right" and fr.lanes_same_direction > 1:
        return -(edge - width / 2 - 0.15)
    return -(edge + 0.2) if side == "right" else edge + 0.2


def _ego_lane(ego: EgoTemplate, asset: str, width: float) -> float:
    return ego.frame.lane_d(ego.ego_lane)


def _adjacent_lane(ego: EgoTemplate, asset: str, width: float) -> float:
    return ego.frame.lane_d(0 if ego.ego_lane == 1 else 1)


def _oncoming_lane(ego: EgoTemplate, asset: str, width: float) -> float:
    return ego.frame.lane_d(-1)


def _right_side(ego: EgoTemplate, asset: str, width: float) -> float:
    return roadside_d(ego, asset, width, "right")


def _left_side(ego: EgoTemplate, asset: str, width: float) -> float:
    return roadside_d(ego, asset, width, "left")


def _off_the_frame(ego: EgoTemplate, asset: str, width: float) -> float:
    return 0.0  # junction places have coordinates of their own


@dataclass(frozen=True, kw_only=True)
class Location:
    """One start location."""

    name: str
    description: str  # shown to the model
    # lateral offset [m] in the ego's frame of an asset of a width [m] starting here
    lateral: Callable[[EgoTemplate, str, float], float]
    side: Side = "right"  # the road side it is on (the sidewalk a pedestrian starts from)
    needs_junction: bool = False  # only a junction map has it
    needs_second_lane: bool = False  # only a road with two lanes in the ego's direction has it
    behind_ego: bool = False  # behind the ego's start


LOCATIONS: dict[str, Location] = {loc.name: loc for loc in (
    Location(name="ahead_same_lane", lateral=_ego_lane, description="in the ego's lane, ahead of it"),
    Location(name="behind_same_lane", lateral=_ego_lane, behind_ego=True,
             description="in the ego's lane, behind it"),
    Location(name="ahead_adjacent_lane", lateral=_adjacent_lane, needs_second_lane=True,
             description="in the neighbouring lane in the ego's direction, ahead of the ego"),
    Location(name="behind_adjacent_lane", lateral=_adjacent_lane, needs_second_lane=True, behind_ego=True,
             description="in the neighbouring lane in the ego's direction, behind the ego"),
    Location(name="oncoming_lane", lateral=_oncoming_lane,
             description="in the oncoming lane, ahead of the ego, driving towards it"),
    Location(name="roadside_ahead", lateral=_right_side,
             description="at the right road side (sidewalk or curb) ahead of the ego"),
    Location(name="roadside_opposite_ahead", lateral=_left_side, side="left",
             description="at the far (left) road side ahead of the ego"),
    Location(name="crosswalk_ahead", lateral=_ego_lane,
             description="at a crossing point of the road ahead of the ego"),
    Location(name="junction_cross_street", lateral=_off_the_frame, needs_junction=True,
             description="on the street that crosses the ego's road at the junction"),
    Location(name="junction_oncoming", lateral=_off_the_frame, needs_junction=True,
             description="on the junction arm opposite the ego, driving towards the junction"),
    Location(name="junction_corner", lateral=_off_the_frame, needs_junction=True,
             description="at the corner of the junction (traffic lights)"),
)}

# Keywords that map free-text start locations (as the graph's property nodes hold them) to the
# fixed location list; tried in order, all words of an entry must appear.
_LOCATION_WORDS: list[tuple[tuple[str, ...], str]] = [
    (("cross", "street"), "junction_cross_street"),
    (("junction", "opposite"), "junction_oncoming"),
    (("corner",), "junction_corner"),
    (("crosswalk",), "crosswalk_ahead"),
    (("oncoming",), "oncoming_lane"),
    (("opposite", "side"), "roadside_opposite_ahead"),
    (("roadside",), "roadside_ahead"),
    (("sidewalk",), "roadside_ahead"),
    (("curb",), "roadside_ahead"),
    (("behind", "adjacent"), "behind_adjacent_lane"),
    (("behind", "next"), "behind_adjacent_lane"),
    (("behind", "other"), "behind_adjacent_lane"),
    (("behind",), "behind_same_lane"),
    (("front", "adjacent"), "ahead_adjacent_lane"),
    (("ahead", "adjacent"), "ahead_adjacent_lane"),
    (("front",), "ahead_same_lane"),
    (("ahead",), "ahead_same_lane"),
]


def location_from_text(text: str) -> str | None:
    """A start location from free text (exact ids pass through); None when nothing matches."""
    t = text.strip().lower()
    if t in LOCATIONS:
        return t
    words = set(re.findall(r"[a-z]+", t))
    for keys, loc in _LOCATION_WORDS:
        if all(k in words for k in keys):
            return loc
    return None


def lateral_offset(ego: EgoTemplate, location: str, asset: str, width: float) -> float:
    """Lateral offset [m] in the ego's frame of ``asset`` (``width`` [m]) starting at ``location``
    (0 for a location this module does not know)."""
    loc = LOCATIONS.get(location)
    return loc.lateral(ego, asset, width) if loc is not None else 0.0


__all__ = ["LOCATIONS", "Location", "lateral_offset", "location_from_text", "roadside_d"]
