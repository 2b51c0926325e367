"""The policy observation as one fixed-size float32 vector, and the action as a Box.

Layout of the vector (:data:`OBS_NAMES` names every entry), all lengths in metres, speeds in
m/s, times in seconds:

- ego, 9 values: ``x, y`` (map frame), ``cos_heading, sin_heading``, ``speed``,
  ``cruise_speed`` (the speed the route is meant to be driven at), ``length, width``,
  ``time_left`` (until the scenario's duration truncates the episode).
- route, ``2 * N_ROUTE`` values: the route ahead resampled every ``ROUTE_SPACING`` m
  (6, 12, ... 60 m along it), each point ``x, y`` in the ego frame (x forward, y to the left);
  past the route's end the last point repeats.
- actors, ``N_ACTORS`` blocks of ``len(ACTOR_FIELDS)`` values, nearest actor first (centre
  distance), zero-padded (``present`` 0) when fewer actors exist: ``present``; ``x, y``
  relative to the ego in the ego frame; ``cos_heading, sin_heading`` of the actor relative to
  the ego's heading; ``vx, vy`` the actor's velocity over ground in the ego frame;
  ``length, width``; the category one-hot (vehicle, pedestrian, static, light); the light
  one-hot (red, yellow, green; all 0 for off or no light); ``siren_on, brake_lights_on,
  hazard_lights_on, door_open`` as 0/1.

Values are clipped to the bounds of :func:`observation_space`.
"""

from __future__ import annotations

import math

import numpy as np

from regen.core.vectors import finite_vector
from regen.driving.testing.policies import MAX_ACCEL, MAX_BRAKE, ROUTE_AHEAD, Action, Observation
from regen.driving.world.actors import CATEGORIES as ACTOR_CATEGORIES
from regen.driving.world.geometry import to_local

N_ROUTE = 10  # route points in the observation
ROUTE_SPACING = ROUTE_AHEAD / N_ROUTE  # [m] between route points (6 m)
N_ACTORS = 8  # nearest actors in the observation
MAX_CURVATURE = 0.2  # [1/m] the action's curvature bound (turning radius 5 m; a car's limit is 1/length)

MAP_EXTENT = 2000.0  # [m] bound of map coordinates
REL_EXTENT = 200.0  # [m] bound of positions relative to the ego
MAX_SPEED = 60.0  # [m/s] bound of speeds and velocities
MAX_SIZE = 30.0  # [m] bound of lengths and widths
MAX_TIME = 600.0  # [s] bound of time_left

CATEGORIES = tuple(c for c in ACTOR_CATEGORIES if c != "sensor")  # sensors are not observed
LIGHTS = ("red", "yellow", "green")
FLAGS = ("siren", "brake_lights", "hazard_lights", "door")
FLAG_ON = {"siren": "on", "brake_lights": "on", "hazard_lights": "on", "door": "open"}

EGO_FIELDS = ("x", "y", "cos_heading", "sin_heading", "speed", "cruise_speed", "length", "width",
              "time_left")
ACTOR_FIELDS = ("present", "x", "y", "cos_heading", "sin_heading", "vx", "vy", "length", "width",
                *CATEGORIES, *(f"light_{c}" for c in LIGHTS), "siren_on", "brake_lights_on",
                "hazard_lights_on", "door_open")
OBS_NAMES = ([f"ego.{f}" for f in EGO_FIELDS]
             + [f"route{i}.{c}" for i in range(N_ROUTE) for c in ("x", "y")]
             + [f"actor{i}.{f}" for i in range(N_ACTORS) for f in ACTOR_FIELDS])
OBS_SIZE = len(OBS_NAMES)

_EGO_BOUNDS = {"x": MAP_EXTENT, "y": MAP_EXTENT, "cos_heading": 1.0, "sin_heading": 1.0,
               "speed": MAX_SPEED, "cruise_speed": MAX_SPEED, "length": MAX_SIZE, "width": MAX_SIZE,
               "time_left": MAX_TIME}
_ACTOR_BOUNDS = {"x": REL_EXTENT, "y": REL_EXTENT, "cos_heading": 1.0, "sin_heading": 1.0,
                 "vx": MAX_SPEED, "vy": MAX_SPEED}
_NON_NEGATIVE = {"speed", "cruise_speed", "length", "width", "time_left"}


def _bounds() -> tuple[np.ndarray, np.ndarray]:
    low, high = [], []
    for name in OBS_NAMES:
        group, field = name.split(".")
        if group == "ego":
            hi = _EGO_BOUNDS[field]
        elif group.startswith("route"):
            hi = ROUTE_AHEAD + ROUTE_SPACING
        else:
            hi = _ACTOR_BOUNDS.get(field, MAX_SIZE if field in ("length", "width") else 1.0)
        high.append(hi)
        low.append(0.0 if field in _NON_NEGATIVE or (group.startswith("actor") and hi == 1.0
                                                     and "heading" not in field) else -hi)
    return np.asarray(low, np.float32), np.asarray(high, np.float32)


LOW, HIGH = _bounds()


def observation_space():
    """The Box of :func:`encode`'s vectors (float32, shape ``(OBS_SIZE,)``)."""
    from gymnasium import spaces

    return spaces.Box(LOW.copy(), HIGH.copy(), dtype=np.float32)


def action_space(normalized: bool = False):
    """``[acceleration [m/s^2], curvature [1/m]]`` in ``[-MAX_BRAKE, MAX_ACCEL] x
    [-MAX_CURVATURE, MAX_CURVATURE]``, or both in [-1, 1] when ``normalized`` (see
    :func:`decode_action`)."""
    from gymnasium import spaces

    if normalized:
        return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
    return spaces.Box(np.array([-MAX_BRAKE, -MAX_CURVATURE], np.float32),
                      np.array([MAX_ACCEL, MAX_CURVATURE], np.float32), dtype=np.float32)


def decode_action(action: object, normalized: bool = False) -> Action:
    """The policy Action of an action vector, clipped to the action space. Normalized: the first
    entry is full brake at -1, nothing at 0, full throttle at +1; the second scales
    MAX_CURVATURE. ValueError for a non-finite or wrongly shaped action."""
    a = finite_vector(action, 2, "the action [acceleration, curvature]")
    if normalized:
        u, k = float(np.clip(a[0], -1.0, 1.0)), float(np.clip(a[1], -1.0, 1.0))
        return Action(u * (MAX_ACCEL if u > 0 else MAX_BRAKE), k * MAX_CURVATURE)
    return Action(float(np.clip(a[0], -MAX_BRAKE, MAX_ACCEL)),
                  float(np.clip(a[1], -MAX_CURVATURE, MAX_CURVATURE)))


def encode_action(action: Action, normalized: bool = False) -> np.ndarray:
    """The action vector of a policy Action (inverse of :func:`decode_action`, clipped)."""
    a, k = action.acceleration, action.curvature
    if normalized:
        u = a / MAX_ACCEL if a > 0 else a / MAX_BRAKE
        vec = [min(max(u, -1.0), 1.0), min(max(k / MAX_CURVATURE, -1.0), 1.0)]
    else:
        vec = [min(max(a, -MAX_BRAKE), MAX_ACCEL), min(max(k, -MAX_CURVATURE), MAX_CURVATURE)]
    return np.asarray(vec, dtype=np.float32)


def _resampled_route(obs: Observation) -> list[tuple[float, float]]:
    """Route points every ROUTE_SPACING m along [ego, *route_ahead], map frame."""
    ego = obs.ego
    pts = [(ego.x, ego.y), *ego.route_ahead]
    if len(pts) == 1:  # no route: straight ahead
        pts.append((ego.x + ROUTE_AHEAD * math.cos(ego.heading), ego.y + ROUTE_AHEAD * math.sin(ego.heading)))
    out, seg, s0 = [], 0, 0.0  # s0: path length at pts[seg]
    for i in range(1, N_ROUTE + 1):
        target = i * ROUTE_SPACING
        while seg < len(pts) - 1:
            (x0, y0), (x1, y1) = pts[seg], pts[seg + 1]
            length = math.hypot(x1 - x0, y1 - y0)
            if s0 + length >= target and length > 1e-9:
                f = (target - s0) / length
                out.append((x0 + f * (x1 - x0), y0 + f * (y1 - y0)))
                break
            s0 += length
            seg += 1
        else:
            out.append(pts[-1])
    return out


def encode(obs: Observation, time_left: float) -> np.ndarray:
    """The observation vector (layout in the module docstring); ``time_left`` [s]."""
    ego = obs.ego

    def local(x: float, y: float) -> tuple[float, float]:
        return to_local(ego.x, ego.y, ego.heading, x, y)

    vec = [ego.x, ego.y, math.cos(ego.heading), math.sin(ego.heading), ego.speed, ego.cruise_speed,
           ego.length, ego.width, time_left]
    for x, y in _resampled_route(obs):
        vec += local(x, y)
    nearest = sorted(obs.actors, key=lambda a: (math.hypot(a.x - ego.x, a.y - ego.y), a.name))
    for a in nearest[:N_ACTORS]:
        rel = a.heading - ego.heading
        vx, vy = to_local(0.0, 0.0, ego.heading, a.vx, a.vy)  # the velocity turned into the ego frame
        vec += [1.0, *local(a.x, a.y), math.cos(rel), math.sin(rel), vx, vy, a.length, a.width]
        vec += [float(a.category == cat) for cat in CATEGORIES]
        vec += [float(a.light_state == light) for light in LIGHTS]
        vec += [float(getattr(a, f) == FLAG_ON[f]) for f in FLAGS]
    vec += [0.0] * (OBS_SIZE - len(vec))
    return np.clip(np.asarray(vec, dtype=np.float32), LOW, HIGH)


__all__ = ["ACTOR_FIELDS", "EGO_FIELDS", "MAX_CURVATURE", "N_ACTORS", "N_ROUTE", "OBS_NAMES", "OBS_SIZE",
           "ROUTE_SPACING", "action_space", "decode_action", "encode", "encode_action", "observation_space"]
