"""Actor motion primitives: allowed start locations, speed classes and plan building.

A primitive turns solved scalars (start offset ``s`` along the ego's frame [m], speed ``v``
[m/s], trigger time ``t`` [s], distance ``d0`` before the junction [m]) into an
:class:`~regen.driving.plan.ActorPlan` with exact coordinates. The constraints that choose those
scalars live in :mod:`regen.driving.solve`.
"""

from __future__ import annotations

import math

from regen.driving.ego import JUNCTION_CX, MAX_BRAKE, EgoTemplate, arc, stop_distance
from regen.driving.maps import JUNCTION_RADIUS
from regen.driving.plan import ActorPlan

# Start locations, relative to the ego (the model chooses one per entity).
LOCATIONS: dict[str, str] = {
    "ahead_same_lane": "in the ego's lane, ahead of it",
    "behind_same_lane": "in the ego's lane, behind it",
    "ahead_adjacent_lane": "in the neighbouring lane in the ego's direction, ahead of the ego",
    "behind_adjacent_lane": "in the neighbouring lane in the ego's direction, behind the ego",
    "oncoming_lane": "in the oncoming lane, ahead of the ego, driving towards it",
    "roadside_ahead": "at the right road side (sidewalk or curb) ahead of the ego",
    "roadside_opposite_ahead": "at the far (left) road side ahead of the ego",
    "crosswalk_ahead": "at a crossing point of the road ahead of the ego",
    "junction_cross_street": "on the street that crosses the ego's road at the junction",
    "junction_oncoming": "on the junction arm opposite the ego, driving towards the junction",
    "junction_corner": "at the corner of the junction (traffic lights)",
}

# Which start locations each primitive supports.
PRIMITIVE_LOCATIONS: dict[str, tuple[str, ...]] = {
    "stationary": ("ahead_same_lane", "behind_same_lane", "ahead_adjacent_lane", "roadside_ahead",
                   "roadside_opposite_ahead", "crosswalk_ahead", "junction_corner"),
    "drive_forward": ("ahead_same_lane", "behind_same_lane", "ahead_adjacent_lane",
                      "behind_adjacent_lane", "oncoming_lane"),
    "change_lane": ("ahead_adjacent_lane",),
    "cut_in": ("behind_adjacent_lane",),
    "turn_left": ("junction_oncoming",),
    "turn_right": ("junction_cross_street",),
    "run_red_light": ("junction_cross_street",),
    "cross_the_road": ("roadside_ahead", "roadside_opposite_ahead", "crosswalk_ahead"),
    "walk_along": ("roadside_ahead", "roadside_opposite_ahead"),
}

JUNCTION_LOCATIONS = {"junction_cross_street", "junction_oncoming", "junction_corner"}
ADJACENT_LOCATIONS = {"ahead_adjacent_lane", "behind_adjacent_lane"}
BEHIND_LOCATIONS = {"behind_same_lane", "behind_adjacent_lane"}

# Speed classes [m/s] (low, high) for vehicles and for pedestrians.
VEHICLE_SPEEDS = {"slow": (3.0, 7.0), "moderate": (7.0, 12.0), "fast": (12.0, 18.0)}
WALK_SPEEDS = {"slow": (0.8, 1.2), "moderate": (1.2, 1.8), "fast": (1.8, 3.0)}
PEDESTRIAN_ASSETS = {"adult", "child", "pedestrian_group"}
LANE_CHANGE_LENGTH = 20.0  # [m] travelled during a lane change
REACTION_TIME = {"attentive": 1.0, "distracted": 2.2}  # [s] before a follower brakes


def default_location(primitive: str, asset: str) -> str:
    """A sensible start location when none is given."""
    if asset == "traffic_light":
        return "junction_corner"
    if asset in PEDESTRIAN_ASSETS:
        return "roadside_ahead"
    if asset == "parked_car":
        return "roadside_ahead"
    return PRIMITIVE_LOCATIONS.get(primitive, ("ahead_same_lane",))[0]


def scenic_class(asset: str, kind: str) -> str:
    if kind == "sensor":
        return ""
    if asset in PEDESTRIAN_ASSETS:
        return "Pedestrian"
    if kind == "object" and asset != "parked_car":
        return "Object"
    return "Car"


def _straight(fr, s0: float, s1: float, d: float, step: float = 5.0) -> list[tuple[float, float]]:
    n = max(1, int(abs(s1 - s0) // step))
    return [fr.point(s0 + (s1 - s0) * i / n, d) for i in range(n + 1)]


def roadside_d(ego: EgoTemplate, asset: str, width: float, side: str) -> float:
    """Lateral offset [m] of something standing at the road side (pedestrians on the sidewalk,
    vehicles at the curb edge of the outermost lane when it is not the ego's lane)."""
    fr = ego.frame
    if asset in PEDESTRIAN_ASSETS or scenic_class(asset, "object") == "Object" and asset != "parked_car":
        return fr.sidewalk_d(side)
    edge = fr.lanes_same_direction * fr.lane_width
    if side == "right" and fr.lanes_same_direction > 1:
        return -(edge - width / 2 - 0.15)
    # a single lane: park half on the curb so the ego can pass
    return -(edge + 0.2) if side == "right" else edge + 0.2


def build_plan(name: str, asset: str, kind: str, size: tuple[float, float, float], primitive: str,
               location: str, p: dict[str, float], ego: EgoTemplate) -> ActorPlan:
    """The plan of one actor from its solved parameters ``p`` (keys: s, v, t, d0, lane_d)."""
    fr = ego.frame
    length, width, height = size
    cls = scenic_class(asset, kind)
    base = dict(name=name, asset=asset, kind=kind, cls=cls, length=length, width=width,
                height=height, comment=f"{primitive} from {location}")
    s = p.get("s", 0.0)
    v = p.get("v", 0.0)
    t = p.get("t", 0.0)
    h = fr.heading
    if location in JUNCTION_LOCATIONS:
        return _junction_plan(base, primitive, location, p, ego)
    d = p.get("lane_d", 0.0)
    end = 400.0
    if primitive == "stationary":
        x, y = fr.point(s, d)
        return ActorPlan(x=x, y=y, heading=h, **base)
    if primitive == "drive_forward":
        sign = -1.0 if location == "oncoming_lane" else 1.0
        route = _straight(fr, s, s + sign * end, d)
        x, y = route[0]
        sched = [(0.0, v, 0.0)]
        speed0 = v
        if p.get("start_t", 0.0) > 0:  # waits stationary, then departs
            sched = [(0.0, 0.0, 1.0), (p["start_t"], v, 0.0)]
            speed0 = 0.0
        if p.get("brake_t", 0.0) > 0:
            sched.append((p["brake_t"], 0.0, 1.0))
        return ActorPlan(x=x, y=y, heading=h if sign > 0 else h + math.pi, speed0=speed0,
                         route=route, schedule=sched, **base)
    if primitive in ("change_lane", "cut_in"):
        d_to = fr.lane_d(ego.ego_lane)
        s_change = s + v * t
        route = (_straight(fr, s, s_change, d)
                 + _straight(fr, s_change + LANE_CHANGE_LENGTH, s_change + end, d_to)[0:])
        x, y = route[0]
        return ActorPlan(x=x, y=y, heading=h, speed0=v, route=route, schedule=[(0.0, v, 0.0)], **base)
    if primitive in ("cross_the_road", "walk_along"):
        side = "left" if location == "roadside_opposite_ahead" else "right"
        d0 = fr.sidewalk_d(side)
        if primitive == "cross_the_road":
            route = [fr.point(s, d0), fr.point(s, -d0)]
            head = h + (math.pi / 2 if side == "right" else -math.pi / 2)
            sched = [(0.0, 0.0, 0.0), (t, v, 0.0)]
        else:
            route = _straight(fr, s, s - 200.0, d0)
            head = h + math.pi
            sched = [(0.0, v, 0.0)]
        x, y = route[0]
        return ActorPlan(x=x, y=y, heading=head, route=route, schedule=sched, **base)
    raise ValueError(f"no plan for primitive {primitive!r} at {location!r}")


def _junction_plan(base: dict, primitive: str, location: str, p: dict[str, float],
                   ego: EgoTemplate) -> ActorPlan:
    cx, r, w = JUNCTION_CX, JUNCTION_RADIUS, ego.frame.lane_width
    v, d0 = p.get("v", 0.0), p.get("d0", 0.0)
    if primitive == "stationary" or location == "junction_corner":
        x, y = cx - r - 1.0, -(w + 1.5)
        return ActorPlan(x=x, y=y, heading=0.0, **base)
    if location == "junction_cross_street":  # south arm, north-bound
        x0 = cx + w / 2
        start = (x0, -r - d0)
        if primitive == "turn_right":  # into the east arm, east-bound (the ego's direction)
            turn = arc((cx + r, -r), r - w / 2, math.pi, math.pi / 2)
            route = [start] + turn + [(cx + r + 150.0, -w / 2)]
        else:  # straight across (run_red_light, drive_forward)
            route = [start, (x0, 0.0), (x0, r + 150.0)]
        return ActorPlan(x=start[0], y=start[1], heading=math.pi / 2, speed0=v, route=route,
                         schedule=[(0.0, v, 0.0)], **base)
    # junction_oncoming: east arm, west-bound, turning left into the south arm
    start = (cx + r + d0, w / 2)
    turn = arc((cx + r, -r), r + w / 2, math.pi / 2, math.pi)
    route = [start] + turn + [(cx - w / 2, -r - 150.0)]
    return ActorPlan(x=start[0], y=start[1], heading=math.pi, speed0=v, route=route,
                     schedule=[(0.0, v, 0.0)], **base)


def stop_dist(v: float) -> float:
    """Full-brake stopping distance [m] at speed v [m/s]."""
    return stop_distance(v, MAX_BRAKE)
