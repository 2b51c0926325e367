"""The road rules of the NHTSA pre-crash typology (:mod:`regen.driving.verify.typology`): road
departure (7-9), a road user or object in the ego's path (10-15, 36, 37), backing (16), same
direction (17-20), opposite direction (21, 22), lead vehicles (23-27) and evasive action (33, 34)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from regen.driving.verify.typology_junctions import TURNED
from regen.driving.verify.typology_scene import (
    AHEAD,
    HELD,
    MOVING,
    NEAR_IN_TIME,
    OPPOSITE,
    SAME_DIRECTION,
    SIDEWAYS,
    STANDING,
    Scene,
    Track,
    accel,
    backing,
    changing_lane,
    first_time,
    held,
    in_path,
    lead,
    maneuvered,
    maneuvering,
    named,
    net_turn,
    recent,
    runs,
    same_way_at_start,
    sideways_speed,
    steps,
    turning,
)
from regen.driving.world.maps import LANE_WIDTH

CLOSE = 10.0  # [m] bumper gap within which a vehicle entering the ego's lane is close to it
NEAR = 30.0  # [m] centre distance within which a turning vehicle is near another
BRAKE = 1.0  # [m/s^2] deceleration of a braking lead vehicle
ACCELERATING = 0.5  # [m/s^2] acceleration of an accelerating lead vehicle
STEADY = 0.3  # [m/s^2] |acceleration| below this: a steady speed
CLOSING = 1.0  # [m/s] the ego faster than the vehicle ahead by this much closes in on it
STEADY_FOR = 1.0  # [s] a steady or accelerating lead must stay so this long
PARKING_SHIFT = 1.0  # [m] sideways shift of a vehicle pulling over or out
PARKING_SIDEWAYS = 0.2  # [m/s] sideways speed of a vehicle pulling over or out
DRIFT_MIN = 0.05  # [m/s] slowest sideways closing that counts as drifting
DRIFT_CLEARANCE = 0.5  # [m] side-to-side clearance below which a drifting vehicle encroaches
DRIFT_FOR = 1.0  # [s]
ONCOMING_MARGIN = 0.3  # [m] oncoming footprints closer sideways than touching plus this are on a collision course
EVASIVE_TTC = 4.0  # [s] a swerve with a hazard this close in time ahead is evasive
BEHIND = 10.0  # [m] a vehicle this close behind a backing one is in its way

#: the kinds a swerve evades: road users and things that can stand in the ego's way
HAZARDS = ("vehicle", "cyclist", "pedestrian", "animal", "object")


def _path_rule(scene: Scene, kinds: tuple[str, ...], *, maneuver: bool) -> list[str]:
    """Road users of ``kinds`` in the ego's path, the ego maneuvering (or not) around then."""
    out = []
    for t in scene.of_kind(*kinds):
        met = in_path(scene, t)
        if met.any() and maneuvered(scene, met) == maneuver:
            how = "turning or changing lanes" if maneuver else "going straight"
            out.append(f"{named(t)} in the ego's path from t = {first_time(scene, met):.1f} s, the ego {how}")
    return out


# -- 7, 8, 9: road departure ----------------------------------------------------------------------


def _departure(scene: Scene) -> np.ndarray:
    """Where the ego, having been on the road, is off it and moving (the recorded map fact)."""
    on_road = scene.ego.flag("on_road")
    if on_road is None:
        return np.zeros(scene.n, dtype=bool)
    was_on = np.maximum.accumulate(on_road)
    return held(~on_road & was_on & (scene.ego.v > STANDING), HELD, scene.dt)


def road_edge_departure_with_maneuver(scene: Scene) -> list[str]:
    """The ego leaves the road forwards, turning or changing lanes around then."""
    off = _departure(scene) & ~backing(scene.ego, scene.dt)
    return [f"the ego leaves the road at t = {first_time(scene, off):.1f} s after a maneuver"] \
        if off.any() and maneuvered(scene, off) else []


def road_edge_departure_without_maneuver(scene: Scene) -> list[str]:
    """The ego leaves the road going straight."""
    off = _departure(scene) & ~backing(scene.ego, scene.dt)
    return [f"the ego leaves the road at t = {first_time(scene, off):.1f} s going straight"] \
        if off.any() and not maneuvered(scene, off) else []


def road_edge_departure_backing(scene: Scene) -> list[str]:
    """The ego leaves the road backing up."""
    off = _departure(scene) & backing(scene.ego, scene.dt)
    return [f"the ego backs off the road at t = {first_time(scene, off):.1f} s"] if off.any() else []


# -- 10-15, 36, 37: a road user or object in the ego's path ---------------------------------------


def animal_with_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("animal",), maneuver=True)


def animal_without_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("animal",), maneuver=False)


def pedestrian_with_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("pedestrian",), maneuver=True)


def pedestrian_without_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("pedestrian",), maneuver=False)


def pedalcyclist_with_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("cyclist",), maneuver=True)


def pedalcyclist_without_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("cyclist",), maneuver=False)


def object_with_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("object",), maneuver=True)


def object_without_maneuver(scene: Scene) -> list[str]:
    return _path_rule(scene, ("object",), maneuver=False)


# -- 16: backing ----------------------------------------------------------------------------------


def backing_into_vehicle(scene: Scene) -> list[str]:
    """A vehicle (the ego, or one in front of the ego) backs up towards the other, within
    :data:`BEHIND` behind it in its lane."""
    out = []
    for t in scene.of_kind("vehicle"):
        for mover, other in ((scene.ego, t), (t, scene.ego)):
            lon, lat = scene.frame(other, mover)
            behind = (lon < 0) & (-lon - (mover.length + other.length) / 2 <= BEHIND) & (np.abs(lat) < LANE_WIDTH / 2)
            m = backing(mover, scene.dt) & behind
            if m.any():
                who = "the ego" if mover is scene.ego else named(mover)
                whom = "the ego" if other is scene.ego else named(other)
                out.append(f"{who} backs up towards {whom} at t = {first_time(scene, m):.1f} s")
    return out


# -- 17-20: same direction ------------------------------------------------------------------------


def turning_same_direction(scene: Scene) -> list[str]:
    """A vehicle travelling the ego's way turns (:data:`TURNED` or more) while the ego is within
    :data:`NEAR` of it, or the ego turns with such a vehicle near."""
    out = []
    for t in scene.of_kind("vehicle"):
        if not same_way_at_start(scene, t):
            continue
        dist = np.hypot(t.x - scene.ego.x, t.y - scene.ego.y)
        for turner in (t, scene.ego):
            if abs(net_turn(turner, 0, scene.n - 1)) < TURNED:
                continue
            m = turning(turner, scene.dt) & (dist <= NEAR)
            if m.any():
                who = "the ego" if turner is scene.ego else named(turner)
                out.append(f"{who} turns at t = {first_time(scene, m):.1f} s with "
                           f"{'the ego' if turner is t else named(t)} near, both going the same way")
    return out


def parking_same_direction(scene: Scene) -> list[str]:
    """A vehicle travelling the ego's way pulls over to a stop, or pulls out from standing,
    shifting sideways by :data:`PARKING_SHIFT` or more, within :data:`AHEAD` of the driving ego."""
    out = []
    for t in scene.of_kind("vehicle"):
        if not same_way_at_start(scene, t) or abs(net_turn(t, 0, scene.n - 1)) >= TURNED:
            continue
        c, s = math.cos(t.h[0]), math.sin(t.h[0])
        shift = -(t.x - t.x[0]) * s + (t.y - t.y[0]) * c  # sideways from where it started [m]
        pulls_over = t.v.max() > MOVING and t.v[-1] < STANDING
        pulls_out = t.v[0] < STANDING and t.v[-1] > MOVING
        if abs(shift[-1]) < PARKING_SHIFT or not (pulls_over or pulls_out):
            continue
        dist = np.hypot(t.x - scene.ego.x, t.y - scene.ego.y)
        m = (np.abs(sideways_speed(t, scene.dt)) > PARKING_SIDEWAYS) & (dist <= AHEAD) & scene.driving()
        if m.any():
            out.append(f"{named(t)} pulls {'over' if pulls_over else 'out'} near the ego at t = {first_time(scene, m):.1f} s")
    return out


def changing_lanes_same_direction(scene: Scene) -> list[str]:
    """A vehicle travelling the ego's way comes from the next lane into the ego's lane (it, or
    the ego, changing lanes), within :data:`CLOSE` bumper to bumper."""
    out = []
    lane_change = changing_lane(scene.ego, scene.dt)
    for t in scene.of_kind("vehicle"):
        lon, lat = scene.frame(t)
        same_way = np.abs(scene.rel_heading(t)) < SAME_DIRECTION
        close = np.abs(lon) - (scene.ego.length + t.length) / 2 <= CLOSE
        next_lane = (np.abs(lat) >= LANE_WIDTH / 2) & (np.abs(lat) < 1.5 * LANE_WIDTH) & same_way
        moving = recent(changing_lane(t, scene.dt) | lane_change, NEAR_IN_TIME, scene.dt)
        m = ((np.abs(lat) < LANE_WIDTH / 2) & same_way & close & moving & scene.driving()
             & recent(next_lane, NEAR_IN_TIME, scene.dt))
        if m.any():
            k = int(np.argmax(m))
            who = "the ego" if lane_change[max(0, k - steps(NEAR_IN_TIME, scene.dt)):k + 1].any() else named(t)
            out.append(f"{who} changes lanes close to {named(t) if who == 'the ego' else 'the ego'} "
                       f"at t = {k * scene.dt:.1f} s")
    return out


def drifting_same_direction(scene: Scene) -> list[str]:
    """A vehicle alongside the ego, going the same way, and the ego come within
    :data:`DRIFT_CLEARANCE` of each other sideways, closing slower than a lane change
    (:data:`DRIFT_MIN` to :data:`SIDEWAYS`), for :data:`DRIFT_FOR`."""
    out = []
    no_change = ~changing_lane(scene.ego, scene.dt)
    for t in scene.of_kind("vehicle"):
        lon, lat = scene.frame(t)
        alongside = np.abs(lon) <= (scene.ego.length + t.length) / 2 + 2.0
        clearance = np.abs(lat) - (scene.ego.width + t.width) / 2
        closing = -np.gradient(np.abs(lat), scene.dt) if lat.size >= 2 else np.zeros_like(lat)
        m = (alongside & (np.abs(scene.rel_heading(t)) < SAME_DIRECTION) & (clearance < DRIFT_CLEARANCE)
             & (closing >= DRIFT_MIN) & (closing <= SIDEWAYS) & no_change & ~changing_lane(t, scene.dt))
        m = held(m, DRIFT_FOR, scene.dt)
        if m.any():
            out.append(f"{named(t)} and the ego drift together alongside at t = {first_time(scene, m):.1f} s")
    return out


# -- 21, 22: opposite direction -------------------------------------------------------------------


def oncoming(scene: Scene, t: Track) -> np.ndarray:
    """Where ``t`` comes towards the ego, moving, within :data:`AHEAD` ahead, sideways so close
    that their footprints would meet, neither in the junction (turns there are classes 28-32)."""
    _, lat = scene.frame(t)
    gap = scene.gap(t)
    return ((np.abs(scene.rel_heading(t)) > OPPOSITE) & (gap > 0) & (gap <= AHEAD) & (t.v > STANDING)
            & (np.abs(lat) < (scene.ego.width + t.width) / 2 + ONCOMING_MARGIN) & scene.driving()
            & ~scene.in_junction(t) & ~scene.in_junction(scene.ego))


def _opposite(scene: Scene, *, maneuver: bool) -> list[str]:
    out = []
    for t in scene.of_kind("vehicle"):
        m = oncoming(scene, t)
        if m.any() and (maneuvered(scene, m) or maneuvered(scene, m, t)) == maneuver:
            how = "with a maneuver" if maneuver else "both going straight"
            out.append(f"{named(t)} comes head-on in the ego's path at t = {first_time(scene, m):.1f} s, {how}")
    return out


def maneuver_opposite_direction(scene: Scene) -> list[str]:
    return _opposite(scene, maneuver=True)


def no_maneuver_opposite_direction(scene: Scene) -> list[str]:
    return _opposite(scene, maneuver=False)


# -- 23-27: a lead vehicle ------------------------------------------------------------------------


def _lead_rule(scene: Scene, what: str, mask_of: Callable[[Track, np.ndarray], np.ndarray],
               seconds: float = HELD) -> list[str]:
    out = []
    for t in scene.of_kind("vehicle"):
        m = held(lead(scene, t) & mask_of(t, accel(t, scene.dt)), seconds, scene.dt)
        if m.any():
            out.append(f"{named(t)} ahead in the ego's lane {what} at t = {first_time(scene, m):.1f} s")
    return out


def following_vehicle_maneuver(scene: Scene) -> list[str]:
    """The ego turns or changes lanes and, during that or within :data:`NEAR_IN_TIME` after,
    closes in on a vehicle that the maneuver brought ahead of it in its lane (one that was not
    there when the maneuver began: passing the vehicle it leaves behind is not this)."""
    ego, dt = scene.ego, scene.dt
    maneuvers = runs(maneuvering(ego, dt))
    out = []
    for t in scene.of_kind("vehicle"):
        ahead = lead(scene, t)
        closing = ahead & (ego.v > MOVING) & ((ego.v - t.v > CLOSING) | (t.v < STANDING))
        m = np.zeros(scene.n, dtype=bool)
        for a, b in maneuvers:
            if not ahead[a]:
                end = min(b + steps(NEAR_IN_TIME, dt), scene.n)
                m[a:end] |= closing[a:end]
        m = held(m, HELD, dt)
        if m.any():
            out.append(f"{named(t)} comes ahead of the ego by its maneuver and the ego closes in "
                       f"at t = {first_time(scene, m):.1f} s")
    return out


def lead_vehicle_accelerating(scene: Scene) -> list[str]:
    """A vehicle ahead in the ego's lane accelerates (over :data:`ACCELERATING`) for
    :data:`STEADY_FOR` while the ego drives behind it."""
    return _lead_rule(scene, "accelerates", lambda t, a: (a > ACCELERATING) & scene.driving(), STEADY_FOR)


def lead_vehicle_lower_speed(scene: Scene) -> list[str]:
    """A vehicle ahead in the ego's lane moves at a steady speed, :data:`CLOSING` or more slower
    than the ego, for :data:`STEADY_FOR`."""
    ego = scene.ego
    return _lead_rule(scene, "moves slower at a steady speed",
                      lambda t, a: (np.abs(a) < STEADY) & (t.v > STANDING) & (ego.v - t.v > CLOSING), STEADY_FOR)


def lead_vehicle_decelerating(scene: Scene) -> list[str]:
    """A moving vehicle ahead in the ego's lane brakes (over :data:`BRAKE`) while the ego drives."""
    ego = scene.ego
    return _lead_rule(scene, "brakes", lambda t, a: (a < -BRAKE) & (t.v > STANDING) & (ego.v > MOVING))


def lead_vehicle_stopped(scene: Scene) -> list[str]:
    """A vehicle stands ahead in the ego's lane while the ego drives towards it."""
    ego = scene.ego
    return _lead_rule(scene, "stands", lambda t, a: (t.v < STANDING) & (ego.v > MOVING))


# -- 33, 34: evasive action -----------------------------------------------------------------------


def swerves(scene: Scene) -> list[tuple[int, Track]]:
    """(step, hazard): where the ego starts to move sideways while a road user or object in its
    path would be reached within :data:`EVASIVE_TTC`; vehicles and cyclists moving ahead the
    ego's way are passed, not evaded."""
    ego, dt = scene.ego, scene.dt
    lc = changing_lane(ego, dt)
    starts = np.flatnonzero(lc[1:] & ~lc[:-1]) + 1
    if lc.size and lc[0]:
        starts = np.concatenate([[0], starts])
    out = []
    for k in (int(s) for s in starts):
        lo = max(0, k - steps(HELD, dt))
        for t in scene.of_kind(*HAZARDS):
            if not in_path(scene, t)[lo:k + 1].any():
                continue
            rel = scene.rel_heading(t)[k]
            if t.kind in ("vehicle", "cyclist") and abs(rel) < SAME_DIRECTION and t.v[k] > STANDING:
                continue
            lon, _ = scene.frame(t)
            closing = ego.v[k] - t.v[k] * math.cos(rel)
            if closing > 0 and (lon[k] - ego.length / 2) / closing <= EVASIVE_TTC:
                out.append((k, t))
    return out


def _evasive(scene: Scene, *, maneuver: bool) -> list[str]:
    out = []
    prior = turning(scene.ego, scene.dt) | backing(scene.ego, scene.dt)
    for k, t in swerves(scene):
        before = bool(prior[max(0, k - steps(NEAR_IN_TIME, scene.dt)):k].any())
        if before == maneuver:
            out.append(f"the ego swerves away from {named(t)} at t = {k * scene.dt:.1f} s"
                       + (" after a turn" if maneuver else ""))
    return out


def evasive_with_maneuver(scene: Scene) -> list[str]:
    return _evasive(scene, maneuver=True)


def evasive_without_maneuver(scene: Scene) -> list[str]:
    return _evasive(scene, maneuver=False)


#: the rules of this module, each named as its class's id
RULES = (road_edge_departure_with_maneuver, road_edge_departure_without_maneuver, road_edge_departure_backing,
         animal_with_maneuver, animal_without_maneuver, pedestrian_with_maneuver, pedestrian_without_maneuver,
         pedalcyclist_with_maneuver, pedalcyclist_without_maneuver, backing_into_vehicle, turning_same_direction,
         parking_same_direction, changing_lanes_same_direction, drifting_same_direction,
         maneuver_opposite_direction, no_maneuver_opposite_direction, following_vehicle_maneuver,
         lead_vehicle_accelerating, lead_vehicle_lower_speed, lead_vehicle_decelerating, lead_vehicle_stopped,
         evasive_with_maneuver, evasive_without_maneuver, object_with_maneuver, object_without_maneuver)

__all__ = ["RULES", "animal_with_maneuver", "animal_without_maneuver", "backing_into_vehicle", "changing_lanes_same_direction",
           "drifting_same_direction", "evasive_with_maneuver", "evasive_without_maneuver",
           "following_vehicle_maneuver", "lead_vehicle_accelerating", "lead_vehicle_decelerating",
           "lead_vehicle_lower_speed", "lead_vehicle_stopped", "maneuver_opposite_direction",
           "no_maneuver_opposite_direction", "object_with_maneuver", "object_without_maneuver", "oncoming",
           "parking_same_direction", "pedalcyclist_with_maneuver", "pedalcyclist_without_maneuver",
           "pedestrian_with_maneuver", "pedestrian_without_maneuver", "road_edge_departure_backing",
           "road_edge_departure_with_maneuver", "road_edge_departure_without_maneuver", "swerves",
           "turning_same_direction"]
