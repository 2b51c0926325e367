"""Driving policies under test: what a policy sees, what it returns, and the built-in ones.

A policy is any callable ``policy(observation: Observation) -> Action`` (a pair
``(acceleration, curvature)`` is accepted too). It is called every simulation step (10 Hz with the
default step of 0.1 s), before the step is simulated. An object with a ``reset()`` method has it
called at the start of every episode, so a policy may keep state between steps.

The action is **acceleration [m/s^2] and curvature [1/m]**:

- ``acceleration`` along the ego's heading; the Newtonian model realizes it exactly between
  -6.8 m/s^2 (full brake) and +5.6 m/s^2 (full throttle) and clips beyond; the ego never reverses.
- ``curvature`` of the path, positive to the left (counter-clockwise); the heading then changes
  at ``speed * curvature`` [rad/s]. Limited to 1/length of the car.

Built in (:data:`BUILTIN`): ``constant-speed`` (holds the route's cruise speed, ignores everyone),
``idm`` (Intelligent Driver Model behind the nearest actor in the ego's path; stops for red and
yellow lights near its path; yields to pedestrians and crossing actors about to enter its path;
stops for an emergency vehicle with its siren on that comes closer within 40 m),
``aeb`` (constant speed plus full emergency braking when the time to collision with something in
its path falls below 1.5 s). All steer along the route (:func:`route_curvature`). ``regen test``
also knows ``reference`` (:data:`regen.driving.testing.harness.BUILTIN`): the careful driver of
the but-for check, :mod:`regen.driving.testing.reference`.

:func:`load_policy` resolves a SPEC: a built-in name, ``module:callable`` or
``path/to/file.py:callable`` (imported by file path, so a file outside the repository works).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from regen.driving.world.geometry import DOOR_WIDTH

MAX_ACCEL = 5.6  # Newtonian full-throttle acceleration [m/s^2]
MAX_BRAKE = 6.8  # Newtonian full-brake deceleration [m/s^2]
ROUTE_AHEAD = 60.0  # the observation's route reaches this far ahead of the ego [m]

Point = tuple[float, float]  # (x, y) [m], map frame


@dataclass(frozen=True, kw_only=True)
class EgoState:
    """The ego as the policy sees it."""

    x: float  # centre [m], map frame
    y: float  # centre [m]
    heading: float  # [rad], counter-clockwise from +x
    speed: float  # [m/s], never negative
    length: float  # [m]
    width: float  # [m]
    cruise_speed: float  # the speed the route is meant to be driven at [m/s]
    route_ahead: tuple[Point, ...]  # next waypoints [m], nearest first, up to ROUTE_AHEAD away


@dataclass(frozen=True, kw_only=True)
class ActorState:
    """Another road user or object (sensors are not observed)."""

    name: str
    category: str  # 'vehicle', 'pedestrian', 'static', 'light'
    asset: str  # database asset, e.g. 'sedan', 'adult', 'traffic_light'
    x: float  # centre [m]
    y: float  # centre [m]
    heading: float  # [rad], counter-clockwise from +x
    vx: float  # velocity [m/s]
    vy: float  # velocity [m/s]
    length: float  # [m]
    width: float  # [m]
    # visible properties; None where the actor has no such property
    light_state: str | None = None  # traffic lights: 'green', 'yellow', 'red', 'off'
    siren: str | None = None  # 'on', 'off'
    brake_lights: str | None = None  # 'on', 'off'
    hazard_lights: str | None = None  # 'on', 'off'
    door: str | None = None  # 'open', 'closed'

    @property
    def speed(self) -> float:
        """[m/s]"""
        return math.hypot(self.vx, self.vy)


@dataclass(frozen=True, kw_only=True)
class Observation:
    t: float  # simulation time [s]
    dt: float  # step [s]
    ego: EgoState
    actors: tuple[ActorState, ...]


@dataclass(frozen=True)
class Action:
    acceleration: float  # [m/s^2] along the heading; realized within [-6.8, 5.6]
    curvature: float = 0.0  # [1/m], positive to the left


Policy = Callable[[Observation], "Action | tuple[float, float]"]


def as_action(value: object) -> Action:
    """A policy's return value as an Action; ValueError naming what is wrong (NaN, type)."""
    if isinstance(value, Action):
        a, k = value.acceleration, value.curvature
    elif isinstance(value, (tuple, list)) and len(value) == 2:
        a, k = value
    else:
        raise ValueError(f"the policy returned {type(value).__name__}, not an Action or an "
                         "(acceleration, curvature) pair")
    try:
        a, k = float(a), float(k)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"the policy's action is not numeric: {value!r}") from exc
    if not (math.isfinite(a) and math.isfinite(k)):
        raise ValueError(f"the policy's action is not finite: acceleration={a}, curvature={k}")
    return Action(a, k)


# --- geometry shared by the built-in policies ---------------------------------------------------


def route_curvature(ego: EgoState, lookahead: float | None = None) -> float:
    """Pure-pursuit curvature [1/m] towards the route point ``lookahead`` [m] ahead."""
    ld = lookahead if lookahead is not None else max(4.0, 0.8 * ego.speed)
    target = None
    for px, py in ego.route_ahead:
        if math.hypot(px - ego.x, py - ego.y) >= ld:
            target = (px, py)
            break
    if target is None:
        if not ego.route_ahead:
            return 0.0
        target = ego.route_ahead[-1]
    dx, dy = target[0] - ego.x, target[1] - ego.y
    dist = math.hypot(dx, dy)
    if dist < 0.5:
        return 0.0
    c, s = math.cos(ego.heading), math.sin(ego.heading)
    alpha = math.atan2(c * dy - s * dx, c * dx + s * dy)
    return 2.0 * math.sin(alpha) / dist


def _path(ego: EgoState) -> list[tuple[float, float, float, float, float]]:
    """Segments (x0, y0, ux, uy, s0) of the path ahead from the ego's centre; s0 [m] along it."""
    pts = [(ego.x, ego.y), *ego.route_ahead]
    out, s = [], 0.0
    for (x0, y0), (x1, y1) in zip(pts, pts[1:], strict=False):
        seg = math.hypot(x1 - x0, y1 - y0)
        if seg < 1e-6:
            continue
        out.append((x0, y0, (x1 - x0) / seg, (y1 - y0) / seg, s))
        s += seg
    if not out:  # no route: straight ahead
        out.append((ego.x, ego.y, math.cos(ego.heading), math.sin(ego.heading), 0.0))
    return out


def path_frame(ego: EgoState, x: float, y: float) -> tuple[float, float, float, float]:
    """(s [m] along the path ahead from the ego's centre, lateral offset [m], ux, uy): the point
    in the frame of its nearest path segment, and that segment's direction. The first segment
    extends backwards and the last forwards without end."""
    segs = _path(ego)
    best = (math.inf, 0.0, 0.0, 1.0, 0.0)
    for i, (x0, y0, ux, uy, s0) in enumerate(segs):
        rx, ry = x - x0, y - y0
        lon = rx * ux + ry * uy
        lat = -rx * uy + ry * ux
        lo = -math.inf if i == 0 else 0.0
        hi = segs[i + 1][4] - s0 if i + 1 < len(segs) else math.inf
        err = math.hypot(lon - min(max(lon, lo), hi), lat)
        if err < best[0]:
            best = (err, s0 + lon, lat, ux, uy)
    return best[1], best[2], best[3], best[4]


@dataclass(frozen=True)
class Obstacle:
    """Something in the ego's path: bumper-to-bumper gap [m] and its speed along the path [m/s]."""

    gap: float
    speed: float
    name: str


def _reach(ego: EgoState, a: ActorState) -> float:
    """Lateral distance [m] within which the actor's centre blocks the ego's path."""
    door = DOOR_WIDTH if a.door == "open" else 0.0  # an open door sticks out on the left
    return ego.width / 2 + max(a.width, a.length if a.category == "pedestrian" else a.width) / 2 + door + 0.3


def walks_along(along: float, lat: float, lat_rate: float) -> bool:
    """Whether a pedestrian beside the path walks along it (0.5 m/s or more along the path and
    not towards it): a driver passes one on the pavement, as it would not one standing at the
    kerb or stepping off it."""
    return abs(along) >= 0.5 and not (lat * lat_rate < 0 and abs(lat_rate) > 0.2)


def obstacles_in_path(obs: Observation, *, horizon: float = 0.0,
                      pedestrian_margin: float = 0.0) -> list[Obstacle]:
    """Actors in the ego's path ahead, nearest first; with ``horizon`` [s] > 0 also those whose
    constant-velocity motion brings them into the path within that time (crossing actors), as
    stopped obstacles where they will enter it. A pedestrian standing or stepping towards the path
    counts as in it also within ``pedestrian_margin`` [m] beside it (a yielding driver waits until
    it has stepped clear); one walking along beside the path (:func:`walks_along`) does not."""
    ego = obs.ego
    out: list[Obstacle] = []
    for a in obs.actors:
        if a.category == "light":
            continue
        s, lat, ux, uy = path_frame(ego, a.x, a.y)
        front = s - ego.length / 2 - max(a.length, a.width) / 2
        if s <= 0 or s > ROUTE_AHEAD + ego.length:
            continue
        along = a.vx * ux + a.vy * uy
        lat_rate = -a.vx * uy + a.vy * ux
        reach = _reach(ego, a)
        if a.category == "pedestrian" and abs(lat) > reach and not walks_along(along, lat, lat_rate):
            reach += pedestrian_margin  # at the kerb, or stepping towards the path
        if abs(lat) <= reach:
            out.append(Obstacle(front, along, a.name))
            continue
        if horizon > 0:
            if lat * lat_rate < 0 and abs(lat_rate) > 0.2:  # moving towards the path
                t_in = (abs(lat) - reach) / abs(lat_rate)
                if t_in <= horizon:
                    out.append(Obstacle(front + along * t_in, 0.0, a.name))
    return sorted(out, key=lambda o: o.gap)


def red_lights_ahead(obs: Observation, *, reach: float = 12.0, stop_line: float = 2.0,
                     states: tuple[str, ...] = ("red", "yellow")) -> list[Obstacle]:
    """Red or yellow lights (``states``) ahead within ``reach`` [m] of the ego's path, as stop
    lines (lights carry no facing direction in this toolkit: every light near the path applies)."""
    ego = obs.ego
    out = []
    for a in obs.actors:
        if a.category != "light" or a.light_state not in states:
            continue
        s, lat, _, _ = path_frame(ego, a.x, a.y)
        gap = s - stop_line - ego.length / 2
        if abs(lat) <= reach and gap > -0.5:
            if a.light_state == "yellow" and gap < ego.speed ** 2 / (2 * 3.0):
                continue  # too close to stop comfortably on yellow: go through
            out.append(Obstacle(max(gap, 0.0), 0.0, a.name))
    return out


def dark_lights_ahead(obs: Observation, *, reach: float = 12.0, stop_line: float = 2.0) -> list[Obstacle]:
    """Dark lights (``light_state`` off: out of order) ahead, as stop lines like red ones."""
    return red_lights_ahead(obs, reach=reach, stop_line=stop_line, states=("off",))


def sirens_closing(obs: Observation, *, reach: float = 40.0, stop_in: float = 12.0) -> list[Obstacle]:
    """A stop line ``stop_in`` [m] ahead for each emergency vehicle with its siren on within
    ``reach`` [m] that is coming closer (drivers stop and let it pass), else nothing."""
    ego = obs.ego
    ex, ey = ego.x, ego.y
    evx, evy = ego.speed * math.cos(ego.heading), ego.speed * math.sin(ego.heading)
    out = []
    for a in obs.actors:
        if a.siren != "on":
            continue
        dx, dy = a.x - ex, a.y - ey
        dist = math.hypot(dx, dy)
        closing = -(dx * (a.vx - evx) + dy * (a.vy - evy)) / max(dist, 1e-6)
        if dist <= reach and closing > 0.5:
            out.append(Obstacle(stop_in, 0.0, a.name))
    return out


# --- the built-in policies ----------------------------------------------------------------------


def _hold(speed: float, target: float, gain: float = 1.5) -> float:
    return max(-MAX_BRAKE, min(MAX_ACCEL, gain * (target - speed)))


def constant_speed(obs: Observation) -> Action:
    """Hold the route's cruise speed and follow the route; ignores every other actor."""
    return Action(_hold(obs.ego.speed, obs.ego.cruise_speed), route_curvature(obs.ego))


@dataclass
class IDM:
    """Intelligent Driver Model (Treiber et al. 2000) on the nearest obstacle in the path."""

    time_headway: float = 1.5  # T [s]
    min_gap: float = 2.0  # s0 [m]
    max_accel: float = 2.0  # a [m/s^2]
    comfort_decel: float = 3.0  # b [m/s^2]
    delta: float = 4.0
    yield_horizon: float = 3.0  # [s]: crossing actors entering the path this soon are yielded to
    # [m] beside its path within which a pedestrian is still yielded to: it stops and waits
    # until the pedestrian has stepped clear, rather than rolling past its back
    pedestrian_margin: float = 1.5

    def __call__(self, obs: Observation) -> Action:
        ego = obs.ego
        v, v0 = ego.speed, max(ego.cruise_speed, 0.1)
        acc = self.max_accel * (1.0 - (v / v0) ** self.delta)
        ahead = (obstacles_in_path(obs, horizon=self.yield_horizon, pedestrian_margin=self.pedestrian_margin)
                 + red_lights_ahead(obs) + sirens_closing(obs))
        if ahead:
            lead = min(ahead, key=lambda o: o.gap)
            dv = v - max(lead.speed, 0.0)
            s_star = self.min_gap + max(0.0, v * self.time_headway
                                        + v * dv / (2 * math.sqrt(self.max_accel * self.comfort_decel)))
            acc -= self.max_accel * (s_star / max(lead.gap, 0.1)) ** 2
        return Action(max(-MAX_BRAKE, min(MAX_ACCEL, acc)), route_curvature(ego))


@dataclass
class AEB:
    """Constant speed, plus full braking while the time to collision with something in the path
    is below ``ttc_threshold`` [s] (or it is closer than ``min_gap`` [m])."""

    ttc_threshold: float = 1.5  # [s]
    min_gap: float = 2.0  # [m]

    def __call__(self, obs: Observation) -> Action:
        ego = obs.ego
        for o in obstacles_in_path(obs):
            closing = ego.speed - o.speed
            if o.gap < self.min_gap or (closing > 0.1 and o.gap / closing < self.ttc_threshold):
                return Action(-MAX_BRAKE, route_curvature(ego))
        return constant_speed(obs)


BUILTIN: dict[str, Callable[[], Policy]] = {
    "constant-speed": lambda: constant_speed,
    "idm": IDM,
    "aeb": AEB,
}


def load_policy(spec: str) -> Policy:
    """The policy a SPEC names: a built-in name ({builtins}), ``module:callable`` or
    ``path/to/file.py[:callable]`` (default callable: ``policy``). A built-in and a class are instantiated; ConfigError if the
    SPEC names nothing callable."""
    from regen.harness.loading import load_callable

    return load_callable(spec, BUILTIN)


load_policy.__doc__ = (load_policy.__doc__ or "").format(builtins=", ".join(BUILTIN))

__all__ = ["AEB", "BUILTIN", "IDM", "Action", "ActorState", "EgoState", "Observation", "Obstacle",
           "Policy", "as_action", "constant_speed", "load_policy", "obstacles_in_path",
           "dark_lights_ahead", "path_frame", "red_lights_ahead", "route_curvature"]
