"""What the pre-crash typology's rules read of a scenario: every actor's track with its kind, the
ego's frame, the junction, and the motions the rules name (:mod:`regen.driving.verify.typology`).

Everything here is computed from the trace (poses, speeds, headings and the map facts the
simulation records per step), never from the model's text. Arrays hold one value per step.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from regen.core.scenario import Scenario
from regen.core.trace import ActorTrack, Trace
from regen.driving.assets import database
from regen.driving.world.egos import JUNCTION_CX
from regen.driving.world.maps import GEOMETRIES, LANE_WIDTH

# -- thresholds, each with its unit --------------------------------------------------------------
MOVING = 1.0  # [m/s] the ego counts as driving above this speed
STANDING = 0.5  # [m/s] a road user counts as standing below this speed
TURN_RATE = 0.15  # [rad/s] yaw rate of a turn (the 'turning' predicate's)
TURN_MIN = math.radians(25)  # [rad] heading change over a stretch of yaw that makes it a turn
SIDEWAYS = 0.4  # [m/s] sideways speed of a lane change (the 'changing_lane' predicate's)
BACKING = 0.3  # [m/s] speed against the heading that counts as backing up
HELD = 0.5  # [s] a motion counts when it holds at least this long
AFTER_TURN = 2.0  # [s] sideways motion this close to a turn belongs to the turn, not a lane change
NEAR_IN_TIME = 3.0  # [s] 'around' a moment: this long before or after it
SAME_DIRECTION = math.radians(30)  # [rad] headings closer than this: the same direction
OPPOSITE = math.radians(150)  # [rad] headings further apart than this: opposite directions
APPROACH = 40.0  # [m] a vehicle this close to the junction, heading into it, approaches it
AHEAD = 40.0  # [m] a road user this far ahead of the ego's front, in its lane, is in its path

#: kinds of road users and things by asset; the database's categories decide, then these words
#: (an asset of a database that adds animals or stop signs, or one an imported file names)
ANIMAL_WORDS = ("animal", "dog", "deer", "cat", "horse", "cow", "moose", "elk", "sheep", "goat", "fox", "boar")
KIND_OF_CATEGORY = {"vehicles": "vehicle", "pedestrians": "pedestrian", "static objects": "object",
                    "traffic": "signal", "sensors": "sensor"}
KIND_WORDS = (("stop_sign", ("stop_sign", "stop sign")), ("animal", ANIMAL_WORDS),
              ("cyclist", ("bicycle", "cyclist", "bike")), ("signal", ("traffic_light", "traffic light")),
              ("pedestrian", ("pedestrian", "person", "child", "adult", "walker")),
              ("vehicle", ("car", "truck", "bus", "van", "vehicle", "motorcycle")),
              ("object", ("debris", "cone", "barrier", "box", "obstacle")))


def _names(words: str, names: tuple[str, ...]) -> bool:
    """Whether one of ``names`` occurs in ``words`` as a whole word (or its plural)."""
    return any(re.search(rf"\b{re.escape(n)}s?\b", words) for n in names)


def actor_kind(asset: str, track_kind: str = "agent") -> str:
    """The kind of an asset for the typology: vehicle, cyclist, pedestrian, animal, object,
    signal, stop_sign, sensor, or other (which no rule reads)."""
    if track_kind == "sensor":
        return "sensor"
    db = database()
    spec = db.assets.get(asset)
    words = " ".join([asset.replace("_", " "), asset, *(spec.aliases if spec else [])]).lower()
    for kind, names in KIND_WORDS[:2]:  # stop signs and animals: whatever their category
        if _names(words, names):
            return kind
    if asset == "bicycle" or (spec is not None and "cyclist" in spec.aliases):
        return "cyclist"  # the database files the bicycle under vehicles
    category = db.category_of(asset) if spec is not None else None
    if category in KIND_OF_CATEGORY:
        return KIND_OF_CATEGORY[category]
    for kind, names in KIND_WORDS[2:]:
        if _names(words, names):
            return kind
    return "object" if track_kind == "object" else "other"


@dataclass(frozen=True)
class Track:
    """One actor over the steps: pose [m, rad], speed [m/s], size [m] and its recorded states."""

    name: str
    asset: str
    kind: str
    x: np.ndarray
    y: np.ndarray
    h: np.ndarray  # heading [rad], counter-clockwise from +x
    v: np.ndarray
    length: float
    width: float
    states: dict[str, list] = field(default_factory=dict)

    @classmethod
    def of(cls, name: str, a: ActorTrack, kind: str | None = None) -> Track:
        n = len(a.x)
        return cls(name=name, asset=a.asset, kind=kind or actor_kind(a.asset, a.kind),
                   x=np.asarray(a.x, float), y=np.asarray(a.y, float),
                   h=np.asarray(a.heading or [0.0] * n, float), v=np.asarray(a.speed or [0.0] * n, float),
                   length=a.length, width=a.width, states=dict(a.states))

    def flag(self, key: str) -> np.ndarray | None:
        """The boolean state ``key`` per step (None when it was not recorded)."""
        vals = self.states.get(key)
        return None if vals is None else np.array([bool(v) for v in vals], dtype=bool)

    def equals(self, key: str, value: str) -> np.ndarray:
        """Where the state ``key`` shows ``value`` (all False when it was not recorded)."""
        vals = self.states.get(key) or [None] * len(self.x)
        return np.array([v is not None and str(v) == value for v in vals], dtype=bool)


# -- motions of one track ------------------------------------------------------------------------


def steps(seconds: float, dt: float) -> int:
    """How many steps ``seconds`` [s] span (at least 1)."""
    return max(1, int(round(seconds / dt)))


def held(mask: np.ndarray, seconds: float, dt: float) -> np.ndarray:
    """Where ``mask`` is part of a run of True at least ``seconds`` [s] long."""
    need = steps(seconds, dt)
    out = np.zeros(mask.size, dtype=bool)
    start = None
    for i, m in enumerate([*mask.tolist(), False]):
        if m and start is None:
            start = i
        elif not m and start is not None:
            if i - start >= need:
                out[start:i] = True
            start = None
    return out


def around(mask: np.ndarray, seconds: float, dt: float) -> np.ndarray:
    """Where ``mask`` holds within ``seconds`` [s] before or after (a dilation in time)."""
    k = steps(seconds, dt)
    out = mask.copy()
    for s in range(1, k + 1):
        out[s:] |= mask[:-s]
        out[:-s] |= mask[s:]
    return out


def accel(t: Track, dt: float) -> np.ndarray:
    """Longitudinal acceleration [m/s^2], smoothed over 3 steps (the 'braking' predicate's)."""
    if t.v.size < 2:
        return np.zeros_like(t.v)
    a = np.gradient(t.v, dt)
    return np.convolve(a, np.ones(3) / 3, mode="same") if a.size >= 3 else a


def yaw_rate(t: Track, dt: float) -> np.ndarray:
    """[rad/s], counter-clockwise positive."""
    h = np.unwrap(t.h)
    return np.gradient(h, dt) if h.size >= 2 else np.zeros_like(h)


def sideways_speed(t: Track, dt: float) -> np.ndarray:
    """Speed [m/s] across the heading the track had a second earlier, left positive (the
    'changing_lane' predicate's measure)."""
    if t.x.size < 2:
        return np.zeros_like(t.x)
    lag = steps(1.0, dt)
    h_ref = np.concatenate([np.full(lag, t.h[0]), t.h[:-lag]])[: t.h.size]
    vx, vy = np.gradient(t.x, dt), np.gradient(t.y, dt)
    return -vx * np.sin(h_ref) + vy * np.cos(h_ref)


def backing(t: Track, dt: float) -> np.ndarray:
    """Where the track moves against its heading faster than :data:`BACKING`, for :data:`HELD`."""
    if t.x.size < 2:
        return np.zeros(t.x.size, dtype=bool)
    vx, vy = np.gradient(t.x, dt), np.gradient(t.y, dt)
    return held(vx * np.cos(t.h) + vy * np.sin(t.h) < -BACKING, HELD, dt)


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in ``mask`` as (first step, step after the last)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def turning(t: Track, dt: float) -> np.ndarray:
    """Where the track turns: its yaw rate stays above :data:`TURN_RATE` for :data:`HELD` and
    the heading changes by :data:`TURN_MIN` or more over that stretch (a lane change bends the
    heading a little one way, then back)."""
    out = held(np.abs(yaw_rate(t, dt)) > TURN_RATE, HELD, dt)
    h = np.unwrap(t.h)
    for a, b in runs(out):
        if abs(h[b - 1] - h[a]) < TURN_MIN:
            out[a:b] = False
    return out


def changing_lane(t: Track, dt: float) -> np.ndarray:
    """Where the track moves sideways faster than :data:`SIDEWAYS` for :data:`HELD`, not within
    :data:`AFTER_TURN` of a turn (the sideways speed is measured against the heading a second
    earlier, so the end of a turn looks sideways for a while)."""
    return held(np.abs(sideways_speed(t, dt)) > SIDEWAYS, HELD, dt) & ~around(turning(t, dt), AFTER_TURN, dt)


def maneuvering(t: Track, dt: float) -> np.ndarray:
    """Where the track turns, changes lanes or backs up: NHTSA's 'vehicle maneuver'."""
    return turning(t, dt) | changing_lane(t, dt) | backing(t, dt)


def road_heading(t: Track, dt: float) -> np.ndarray:
    """The direction of the track's road [rad] per step: its heading, except while it changes
    lanes, when the heading it had a second before the lane change began (a lane change bends the
    heading by some degrees, which would swing everything far ahead out of the lane)."""
    h = t.h.copy()
    lag = steps(1.0, dt)
    for a, b in runs(changing_lane(t, dt)):
        h[a:min(b + lag, h.size)] = t.h[max(0, a - lag)]
    return h


def net_turn(t: Track, start: int, end: int) -> float:
    """Heading change [rad] from step ``start`` to ``end``, left (counter-clockwise) positive."""
    h = np.unwrap(t.h)
    return float(h[min(end, h.size - 1)] - h[max(start, 0)])


def wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles [rad] into [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# -- the scene -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Junction:
    """The junction box: centre (cx, cy) [m] and half its side [m]."""

    cx: float
    cy: float
    half: float


@dataclass(frozen=True)
class Scene:
    """The ego and the other actors of one simulated scenario, with the junction when the map has one."""

    dt: float
    ego: Track
    others: tuple[Track, ...]
    junction: Junction | None = None

    @property
    def n(self) -> int:
        return int(self.ego.x.size)

    def of_kind(self, *kinds: str) -> list[Track]:
        return [t for t in self.others if t.kind in kinds]

    @property
    def signalized(self) -> bool:
        """Whether a traffic light stands in the scene."""
        return any(t.kind == "signal" or "light_state" in t.states for t in self.others)

    @cached_property
    def ego_road(self) -> np.ndarray:
        """The direction of the ego's road per step [rad] (:func:`road_heading`)."""
        return road_heading(self.ego, self.dt)

    def frame(self, t: Track, of: Track | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``t``'s centre in ``of``'s frame: (ahead, to the left) [m] per step. The ego's frame
        (the default) points along its road, also while it changes lanes."""
        o = of or self.ego
        h = self.ego_road if o is self.ego else o.h
        c, s = np.cos(h), np.sin(h)
        dx, dy = t.x - o.x, t.y - o.y
        return dx * c + dy * s, -dx * s + dy * c

    def rel_heading(self, t: Track, of: Track | None = None) -> np.ndarray:
        """``t``'s heading minus ``of``'s (default the ego's) [rad], in [-pi, pi)."""
        return wrap(t.h - (of or self.ego).h)

    def gap(self, t: Track, of: Track | None = None) -> np.ndarray:
        """Bumper-to-bumper distance [m] ahead of ``of`` (default the ego) to ``t`` along
        ``of``'s heading (negative: level with it or behind)."""
        o = of or self.ego
        lon, _ = self.frame(t, o)
        return lon - (o.length + t.length) / 2

    def driving(self) -> np.ndarray:
        """Where the ego drives forwards (faster than :data:`MOVING`, not backing up) within
        :data:`NEAR_IN_TIME`."""
        return around((self.ego.v > MOVING) & ~backing(self.ego, self.dt), NEAR_IN_TIME, self.dt)

    def in_junction(self, t: Track) -> np.ndarray:
        """Where the track's centre is inside the junction (the recorded map fact, else the box)."""
        rec = t.flag("in_junction")
        if rec is not None:
            return rec
        if self.junction is None:
            return np.zeros(t.x.size, dtype=bool)
        j = self.junction
        return (np.abs(t.x - j.cx) < j.half) & (np.abs(t.y - j.cy) < j.half)

    def approaching(self, t: Track) -> np.ndarray:
        """Where the track is in the junction, or within :data:`APPROACH` of it heading into it."""
        inside = self.in_junction(t)
        if self.junction is None:
            return inside
        j = self.junction
        dx, dy = j.cx - t.x, j.cy - t.y
        box = np.hypot(np.maximum(np.abs(dx) - j.half, 0.0), np.maximum(np.abs(dy) - j.half, 0.0))
        towards = (np.cos(t.h) * dx + np.sin(t.h) * dy) > 0.3 * np.hypot(dx, dy)
        return inside | ((box <= APPROACH) & towards)


# -- what the rules share ---------------------------------------------------------------------


def first_time(scene: Scene, mask: np.ndarray) -> float:
    """The time [s] of the first step of ``mask``."""
    return float(np.argmax(mask)) * scene.dt


def named(t: Track) -> str:
    """How lines name an actor: its name and asset."""
    return f"{t.name} ({t.asset})"


def recent(mask: np.ndarray, seconds: float, dt: float) -> np.ndarray:
    """Where ``mask`` held at some step within the last ``seconds`` [s], this one included."""
    out = mask.copy()
    for s in range(1, steps(seconds, dt) + 1):
        out[s:] |= mask[:-s]
    return out


def maneuvered(scene: Scene, mask: np.ndarray, track: Track | None = None) -> bool:
    """Whether ``track`` (default the ego) turns, changes lanes or backs up from
    :data:`NEAR_IN_TIME` before the first step of ``mask`` to its last: a prior maneuver."""
    if not mask.any():
        return False
    idx = np.flatnonzero(mask)
    lo = max(0, int(idx[0]) - steps(NEAR_IN_TIME, scene.dt))
    return bool(maneuvering(track or scene.ego, scene.dt)[lo:int(idx[-1]) + 1].any())


def in_path(scene: Scene, t: Track) -> np.ndarray:
    """Where ``t``'s centre is in the ego's lane, ahead of its front by at most :data:`AHEAD`,
    while the ego drives (around that moment)."""
    lon, lat = scene.frame(t)
    ahead = lon - scene.ego.length / 2
    return (ahead > 0) & (ahead <= AHEAD) & (np.abs(lat) < LANE_WIDTH / 2) & scene.driving()


def lead(scene: Scene, t: Track) -> np.ndarray:
    """Where ``t`` drives ahead of the ego in its lane, the same way, within :data:`AHEAD`
    bumper to bumper."""
    _, lat = scene.frame(t)
    gap = scene.gap(t)
    return ((gap > 0) & (gap <= AHEAD) & (np.abs(lat) < LANE_WIDTH / 2)
            & (np.abs(scene.rel_heading(t)) < SAME_DIRECTION))


def same_way_at_start(scene: Scene, t: Track) -> bool:
    """Whether ``t`` travels the ego's way at the first step."""
    return bool(abs(wrap(t.h[0] - scene.ego.h[0])) < SAME_DIRECTION)


def junction_of(trace: Trace, tracks: list[Track]) -> Junction | None:
    """The junction of the trace's map: the generated maps' geometry, else the box around every
    point an actor was recorded inside one; None on a map without a junction."""
    geo = GEOMETRIES.get(str(trace.meta.get("map", "")))
    if geo is not None:
        return Junction(JUNCTION_CX, 0.0, geo.junction_radius) if geo.junction else None
    xs, ys = [], []
    for t in tracks:
        inside = t.flag("in_junction")
        if inside is not None and inside.any():
            xs += t.x[inside].tolist()
            ys += t.y[inside].tolist()
    if not xs:
        return None
    cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
    return Junction(cx, cy, max(max(xs) - min(xs), max(ys) - min(ys), LANE_WIDTH) / 2)


def robot_name(scenario: Scenario, trace: Trace) -> str | None:
    """The robot's track in the trace: the scenario's robot entity, else a track of kind ego/robot."""
    robot = scenario.robot()
    if robot is not None and robot.name in trace.actors:
        return robot.name
    return next((n for n, a in trace.actors.items() if a.kind in ("ego", "robot")), None)


def scene_of(scenario: Scenario, trace: Trace) -> Scene | None:
    """The scene of a simulated scenario; None when the trace has no ego or no steps."""
    ego_name = robot_name(scenario, trace)
    if ego_name is None or trace.steps == 0:
        return None
    assets = {e.name: e.asset for e in scenario.entities}
    tracks = []
    for name, a in trace.actors.items():
        if name == ego_name or len(a.x) != trace.steps:
            continue
        asset = assets.get(name, a.asset)
        tracks.append(Track.of(name, a, actor_kind(asset, a.kind)))
    ego = Track.of(ego_name, trace.actors[ego_name], "ego")
    return Scene(dt=trace.dt, ego=ego, others=tuple(t for t in tracks if t.kind != "sensor"),
                 junction=junction_of(trace, [ego, *tracks]))


__all__ = ["AFTER_TURN", "AHEAD", "APPROACH", "BACKING", "HELD", "MOVING", "NEAR_IN_TIME", "OPPOSITE", "SAME_DIRECTION", "SIDEWAYS",
           "STANDING", "TURN_MIN", "TURN_RATE", "Junction", "Scene", "Track", "accel", "actor_kind", "around", "backing", "first_time", "in_path", "lead", "maneuvered", "recent",
           "named", "same_way_at_start",
           "changing_lane", "held", "junction_of", "maneuvering", "net_turn", "road_heading", "robot_name", "runs", "scene_of",
           "sideways_speed", "steps", "turning", "wrap", "yaw_rate"]
