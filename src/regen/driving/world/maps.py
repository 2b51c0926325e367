"""OpenDRIVE maps the project generates itself (no downloads), cached in the user cache dir.

Three maps, generated with ``scenariogeneration`` on first use and kept under
``regen.paths.cache_dir("maps")`` (Scenic writes a ``.snet`` cache beside each map, so maps never
live in the package folder):

- ``straight``: one straight road along +x, 2 driving lanes each way and a sidewalk each side.
- ``four_way``: a four-way junction at the origin, 1 driving lane each way and sidewalks per arm.
- ``t_junction``: the same without the north arm.

The geometry is fixed and known analytically (:class:`MapGeometry`), so grounding places actors by
exact coordinates without loading the map: lane centres, arm directions and the junction box.
"""

from __future__ import annotations

import hashlib
import logging
import math
from dataclasses import dataclass
from pathlib import Path

from regen.core.io import atomic_write_text
from regen.errors import ConfigError, DependencyNotInstalled
from regen.paths import cache_dir

log = logging.getLogger(__name__)

LANE_WIDTH = 3.5  # driving lane width [m]
SIDEWALK_WIDTH = 2.0  # [m]
STRAIGHT_LENGTH = 400.0  # [m], the straight road spans x in [-200, 200]
ARM_LENGTH = 150.0  # [m] length of each junction arm
JUNCTION_RADIUS = 12.0  # [m] from the junction centre to where each arm starts
MAP_VERSION = "2"  # bump when the generator changes, so cached maps are regenerated


@dataclass(frozen=True)
class MapGeometry:
    """What grounding needs to know about a generated map, in map coordinates [m]."""

    name: str
    lanes_per_direction: int
    lane_width: float = LANE_WIDTH
    sidewalk_width: float = SIDEWALK_WIDTH
    x_min: float = -STRAIGHT_LENGTH / 2  # straight road extent along x [m]
    x_max: float = STRAIGHT_LENGTH / 2
    junction: bool = False
    arms: tuple[str, ...] = ()  # 'west', 'east', 'south', 'north'
    junction_radius: float = JUNCTION_RADIUS

    def lane_center_y(self, lane: int) -> float:
        """Lateral centre [m] of an east-bound lane on the horizontal road.

        ``lane`` 0 is the innermost east-bound lane (next to the centre line), 1 the next one out;
        negative indices are west-bound lanes (-1 innermost). East-bound traffic drives at y < 0
        (right-hand traffic on a road whose reference line points +x).
        """
        if lane >= 0:
            return -(lane + 0.5) * self.lane_width
        return (-lane - 0.5) * self.lane_width

    def sidewalk_y(self, side: str) -> float:
        """Lateral centre [m] of the right ('right', y < 0) or left sidewalk."""
        off = self.lanes_per_direction * self.lane_width + self.sidewalk_width / 2
        return -off if side == "right" else off

    @property
    def road_half_width(self) -> float:
        """From the centre line to the outer edge of the driving lanes [m]."""
        return self.lanes_per_direction * self.lane_width


GEOMETRIES: dict[str, MapGeometry] = {
    "straight": MapGeometry("straight", lanes_per_direction=2),
    "four_way": MapGeometry("four_way", lanes_per_direction=1, junction=True,
                            arms=("west", "east", "south", "north"),
                            x_min=-(JUNCTION_RADIUS + ARM_LENGTH), x_max=JUNCTION_RADIUS + ARM_LENGTH),
    "t_junction": MapGeometry("t_junction", lanes_per_direction=1, junction=True,
                              arms=("west", "east", "south"),
                              x_min=-(JUNCTION_RADIUS + ARM_LENGTH), x_max=JUNCTION_RADIUS + ARM_LENGTH),
}


def list_maps() -> list[str]:
    """Names of the maps the project can generate."""
    return list(GEOMETRIES)


def geometry(name: str) -> MapGeometry:
    """The analytic geometry of a map; unknown names raise :class:`ConfigError`."""
    if name not in GEOMETRIES:
        raise ConfigError(f"unknown map {name!r}; choose one of: {', '.join(GEOMETRIES)}")
    return GEOMETRIES[name]


def _xodr():
    try:
        from scenariogeneration import xodr
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled("scenariogeneration", "driving", "generating OpenDRIVE maps") from exc
    return xodr


def _road(xodr, road_id: int, length: float, lanes: int):
    """A straight road with ``lanes`` driving lanes each way and a sidewalk on each side."""
    road = xodr.create_road(xodr.Line(length), road_id, left_lanes=lanes, right_lanes=lanes,
                            lane_width=LANE_WIDTH)
    road.add_elevation(0.0, 0.0, 0.0, 0.0, 0.0)  # flat; an empty elevationProfile fails the 1.5 schema
    for section in road.lanes.lanesections:
        walk_r = xodr.Lane(lane_type=xodr.LaneType.sidewalk, a=SIDEWALK_WIDTH)
        walk_r.add_roadmark(xodr.std_roadmark_solid())
        walk_l = xodr.Lane(lane_type=xodr.LaneType.sidewalk, a=SIDEWALK_WIDTH)
        walk_l.add_roadmark(xodr.std_roadmark_solid())
        section.add_right_lane(walk_r)
        section.add_left_lane(walk_l)
    return road


def _build_straight(xodr):
    odr = xodr.OpenDrive("regen_straight")
    road = _road(xodr, 1, STRAIGHT_LENGTH, 2)
    road.planview.set_start_point(-STRAIGHT_LENGTH / 2, 0.0, 0.0)
    odr.add_road(road)
    odr.adjust_roads_and_lanes()
    return odr


# Arm name -> (position of the arm's junction end, heading of the arm pointing into the junction).
_ARMS = {
    "west": (-JUNCTION_RADIUS, 0.0, 0.0),
    "east": (JUNCTION_RADIUS, 0.0, math.pi),
    "south": (0.0, -JUNCTION_RADIUS, math.pi / 2),
    "north": (0.0, JUNCTION_RADIUS, -math.pi / 2),
}


def _build_junction(xodr, name: str, arms: tuple[str, ...]):
    odr = xodr.OpenDrive(f"regen_{name}")
    creator = xodr.CommonJunctionCreator(id=100, name=name, startnum=100)
    ids = {}
    for i, arm in enumerate(arms, start=1):
        road = _road(xodr, i, ARM_LENGTH, 1)
        ids[arm] = i
        x, y, h = _ARMS[arm]
        # 'successor': the arm's reference line runs into the junction, so its right lane
        # (id -1) is the incoming lane and its left lane (id 1) the outgoing one.
        creator.add_incoming_road_cartesian_geometry(road, x, y, h, "successor")
        odr.add_road(road)
    for a in arms:
        for b in arms:
            if a < b:
                # incoming right lane (-1) of one arm to the outgoing left lane (1) of the other,
                # named explicitly or Scenic cannot parse junctions with sidewalks
                creator.add_connection(ids[a], ids[b], lane_one_id=-1, lane_two_id=1)
                creator.add_connection(ids[a], ids[b], lane_one_id=1, lane_two_id=-1)
    odr.add_junction_creator(creator)
    odr.adjust_roads_and_lanes()
    for road in odr.roads.values():  # the junction's connecting roads too: flat, explicitly
        if not road.elevationprofile.elevations:
            road.add_elevation(0.0, 0.0, 0.0, 0.0, 0.0)
    return odr


def _generate(name: str) -> str:
    xodr = _xodr()
    geo = geometry(name)
    odr = _build_straight(xodr) if name == "straight" else _build_junction(xodr, name, geo.arms)
    tmp = cache_dir("maps", ".build") / f"{name}-{hashlib.sha1(name.encode()).hexdigest()[:6]}.xodr"
    odr.write_xml(str(tmp))
    text = tmp.read_text("utf-8")
    tmp.unlink(missing_ok=True)
    return text


def ensure_map(name: str) -> Path:
    """Path of the generated ``.xodr`` for ``name`` (generated on first use, then cached)."""
    geometry(name)  # unknown names fail here, before any import
    folder = cache_dir("maps")
    path = folder / f"{name}-v{MAP_VERSION}.xodr"
    if not path.exists() or path.stat().st_size == 0:
        log.info("generating OpenDRIVE map %s into %s", name, path)
        atomic_write_text(path, _generate(name))
    return path.resolve()
