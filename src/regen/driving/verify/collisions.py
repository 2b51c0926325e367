"""Collisions and infractions of a driving trace, step by step (numpy only, no simulator).

Every actor is an oriented rectangle: centre (x, y), heading, ``length`` along the heading and
``width`` across it, as the trace records them. Two actors collide at a step when their
rectangles overlap (separating-axis test, touching counts). Pairs that are checked: every pair
with at least one vehicle in it (vehicle-vehicle, vehicle-pedestrian, vehicle-static object);
sensors ride on their actor and are never checked, and two actors that never move cannot
collide.

An open door (state ``door`` = 'open') widens its car's footprint by ``DOOR_WIDTH`` on the
driver's (left) side.

Infractions of the ego: running a red light (its front crosses the stop line of a light ahead
of it, within ``LIGHT_REACH`` of its path, while the light shows red; lights carry no facing
direction of their own in this toolkit, so every light near the ego's path applies) and leaving the road (its centre is off the drivable road,
from the trace's ``on_road`` state).

Time to collision (TTC) is the constant-velocity estimate ``gap / closing speed`` [s] with
``gap`` the distance between the two rectangles [m] and the closing speed the rate at which
their centres approach [m/s]; infinite when they do not approach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from regen.core.trace import ActorTrack, Trace
from regen.driving.world.actors import actor_category
from regen.driving.world.geometry import DOOR_WIDTH, corners, door_footprint, gap, overlap, to_local

MIN_CLOSING_SPEED = 0.1  # [m/s] below this two actors are not approaching: TTC is infinite
LIGHT_REACH = 12.0  # [m] lateral distance from the ego's path within which a light applies
STOP_LINE = 2.0  # [m] the stop line lies this far before the light (along the ego's path)


@dataclass(frozen=True, kw_only=True)
class Event:
    """Something that happened at one step."""

    kind: str  # 'collision', 'red_light', 'off_road'
    step: int
    t: float  # [s]
    actors: tuple[str, ...]  # the pair for a collision; (ego, light) or (ego,) for infractions

    def describe(self) -> str:
        if self.kind == "collision":
            return f"collision of {self.actors[0]} and {self.actors[1]} at t={self.t:.1f} s"
        if self.kind == "red_light":
            return f"{self.actors[0]} ran the red light {self.actors[1]} at t={self.t:.1f} s"
        return f"{self.actors[0]} left the road at t={self.t:.1f} s"


@dataclass(frozen=True, kw_only=True)
class PairSafety:
    """One checked pair over the whole trace."""

    a: str
    b: str
    first_collision: float | None  # [s], None: never
    min_distance: float  # [m] smallest gap between the rectangles (0 when they overlap)
    min_ttc: float  # [s] smallest time to collision (0 once they collide, inf: never approach)


@dataclass(frozen=True, kw_only=True)
class SafetyReport:
    """All collisions and infractions of a trace; ``events`` sorted by time."""

    events: list[Event] = field(default_factory=list)  # each collision/infraction where it starts
    pairs: list[PairSafety] = field(default_factory=list)
    colliding: np.ndarray | None = None  # (steps, pairs) bool, in the order of ``pairs``

    @property
    def collisions(self) -> list[Event]:
        return [e for e in self.events if e.kind == "collision"]

    @property
    def first_collision(self) -> Event | None:
        c = self.collisions
        return c[0] if c else None

    def involving(self, actor: str) -> list[PairSafety]:
        return [p for p in self.pairs if actor in (p.a, p.b)]

    def min_ttc(self, actor: str = "ego") -> float:
        """Smallest TTC [s] of ``actor`` with anyone (inf when nothing approaches it)."""
        return min((p.min_ttc for p in self.involving(actor)), default=math.inf)

    def min_distance(self, actor: str = "ego") -> float:
        """Smallest gap [m] between ``actor`` and anyone (inf when nothing is checked)."""
        return min((p.min_distance for p in self.involving(actor)), default=math.inf)


def category(track: ActorTrack) -> str:
    """'vehicle', 'pedestrian', 'static', 'light' or 'sensor' from a trace track."""
    return actor_category(track.asset, track.kind)


def _velocity(trace: Trace, track: ActorTrack) -> tuple[np.ndarray, np.ndarray]:
    """Velocity [m/s] from positions (a walker's recorded heading need not be its direction)."""
    x, y = np.asarray(track.x, float), np.asarray(track.y, float)
    if x.size < 2:
        return np.zeros_like(x), np.zeros_like(y)
    return np.gradient(x, trace.dt), np.gradient(y, trace.dt)


def _moves(track: ActorTrack) -> bool:
    x, y = np.asarray(track.x, float), np.asarray(track.y, float)
    return bool(x.size and (np.ptp(x) > 1e-6 or np.ptp(y) > 1e-6))


def checked_pairs(trace: Trace) -> list[tuple[str, str]]:
    """The pairs whose collisions count (see the module docstring)."""
    names = [n for n, a in trace.actors.items()
             if category(a) not in ("sensor", "light") and a.length > 0 and a.width > 0 and a.x]
    out = []
    for a, b in combinations(names, 2):
        ta, tb = trace.actors[a], trace.actors[b]
        if "vehicle" not in (category(ta), category(tb)):
            continue
        if not (_moves(ta) or _moves(tb)):
            continue
        out.append((a, b))
    return out


def footprint(track: ActorTrack, x: np.ndarray, y: np.ndarray, h: np.ndarray):
    """Centre and width [m] per step, the footprint grown by an open door on the left side."""
    door = track.states.get("door")
    width = np.full(x.size, float(track.width))
    if not door:
        return x, y, width
    return door_footprint(x, y, h, width, np.array([v == "open" for v in door], dtype=bool))


def _starts(mask: np.ndarray) -> np.ndarray:
    """Indices where a run of True begins."""
    prev = np.concatenate([[False], mask[:-1]])
    return np.flatnonzero(mask & ~prev)


def to_stop_line(x, y, heading, length, light_x, light_y) -> tuple[np.ndarray, np.ndarray]:
    """(distance [m] from the front of an ego of ``length`` [m] centred at (x, y) facing
    ``heading`` to the stop line of the light at (light_x, light_y), the light's offset [m] to
    the ego's left); positive distance: the line is still ahead."""
    lon, lat = to_local(x, y, heading, light_x, light_y)
    return lon - STOP_LINE - length / 2, lat


def red_light_events(trace: Trace, ego: str = "ego") -> list[Event]:
    """Steps where the ego's front crosses the stop line of a light near its path, shown red."""
    if ego not in trace.actors:
        return []
    e = trace.actors[ego]
    ex, ey, eh = (np.asarray(v, float) for v in (e.x, e.y, e.heading))
    out = []
    for name, a in trace.actors.items():
        states = a.states.get("light_state")
        if category(a) != "light" or not states:
            continue
        lon, lat = to_stop_line(ex, ey, eh, e.length, np.asarray(a.x, float), np.asarray(a.y, float))
        red = np.array([v is not None and str(v) == "red" for v in states], dtype=bool)
        crossed = np.zeros(trace.steps, dtype=bool)
        crossed[1:] = (lon[:-1] > 0) & (lon[1:] <= 0)
        hit = np.flatnonzero(crossed & red & (np.abs(lat) <= LIGHT_REACH))
        out += [Event(kind="red_light", step=int(k), t=float(trace.times[k]), actors=(ego, name))
                for k in hit]
    return out


def off_road_events(trace: Trace, ego: str = "ego") -> list[Event]:
    """Steps where the ego's centre leaves the drivable road (from the 'on_road' state)."""
    if ego not in trace.actors or "on_road" not in trace.actors[ego].states:
        return []
    on = np.array([bool(v) for v in trace.actors[ego].states["on_road"]], dtype=bool)
    return [Event(kind="off_road", step=int(k), t=float(trace.times[k]), actors=(ego,))
            for k in _starts(~on)]


def analyze(trace: Trace, *, ego: str = "ego") -> SafetyReport:
    """Collisions of every checked pair and the ego's infractions, per step."""
    events: list[Event] = []
    pairs: list[PairSafety] = []
    cols = []
    for a, b in checked_pairs(trace):
        ta, tb = trace.actors[a], trace.actors[b]
        xa, ya, xb, yb = (np.asarray(v, float) for v in (ta.x, ta.y, tb.x, tb.y))
        ha = np.asarray(ta.heading or [0.0] * trace.steps, float)
        hb = np.asarray(tb.heading or [0.0] * trace.steps, float)
        xa, ya, wa = footprint(ta, xa, ya, ha)
        xb, yb, wb = footprint(tb, xb, yb, hb)
        hit = overlap(xa, ya, ha, ta.length, wa, xb, yb, hb, tb.length, wb)
        g = gap(corners(xa, ya, ha, ta.length, wa), corners(xb, yb, hb, tb.length, wb), hit)
        (vax, vay), (vbx, vby) = _velocity(trace, ta), _velocity(trace, tb)
        rx, ry = xb - xa, yb - ya
        dist = np.maximum(np.hypot(rx, ry), 1e-9)
        closing = -(rx * (vbx - vax) + ry * (vby - vay)) / dist
        ttc = np.where(hit, 0.0, np.where(closing > MIN_CLOSING_SPEED, g / np.maximum(closing, 1e-9), np.inf))
        starts = _starts(hit)
        events += [Event(kind="collision", step=int(k), t=float(trace.times[k]), actors=(a, b)) for k in starts]
        pairs.append(PairSafety(a=a, b=b, first_collision=float(trace.times[starts[0]]) if starts.size else None,
                                min_distance=float(g.min()) if g.size else math.inf,
                                min_ttc=float(ttc.min()) if ttc.size else math.inf))
        cols.append(hit)
    events += red_light_events(trace, ego) + off_road_events(trace, ego)
    events.sort(key=lambda e: (e.step, e.kind != "collision", e.actors))
    matrix = np.stack(cols, axis=1) if cols else np.zeros((trace.steps, 0), dtype=bool)
    return SafetyReport(events=events, pairs=pairs, colliding=matrix)


__all__ = ["DOOR_WIDTH", "Event", "PairSafety", "SafetyReport", "analyze", "category", "checked_pairs",
           "footprint", "gap", "off_road_events", "overlap", "red_light_events", "to_stop_line"]
