"""Reactive triggers: an actor's cause action starts on a condition relative to the ego.

Every actor plan is written against the scripted template ego (:mod:`regen.driving.world.egos`): its
schedule and property states are in *template time*, and its cause action starts at the solved
trigger time ``t_trig`` [s]. A :class:`Trigger` says what the template ego is doing at that
moment, so that any ego sets it off in the same situation:

``approach``
    the ego comes near a point (the actor's cause location): the ego has passed it, or its
    distance to go there falls to ``distance`` [m] or below, or its time
    to arrival there (that distance over its speed, when it moves faster than
    :data:`MIN_SPEED`) falls to ``tta`` [s] or below. A faster ego sets it off earlier in space
    (same time to arrival), a slower one at the same distance. The distance to go is measured
    in the ego's frame (the road it is on at its event): how far the point lies ahead along the
    frame plus how far to the side, so an ego still turning into that road (stop_after_turn)
    is measured along its L-shaped way there and the distance shrinks all the way.
``ego_slower``
    the ego's speed falls below ``below`` [m/s] (a follower reacts to the ego's braking).
``offset``
    the actor's offset ahead of the ego along the frame reaches ``offset`` [m] (what it is in
    the template at ``t_trig``) from the side it comes from: from behind when the template's
    offset grows (``rate`` [m/s] > 0, a faster car pulling ahead), from ahead when it shrinks
    (the ego catching up); at the latest at ``late`` [s]. It needs the actor's own position
    (``ax``, ``ay``); without it (the recorded property states, :mod:`regen.driving.simulation.record`,
    which a lane-changing vehicle never switches) it fires at ``late``.
``time``
    absolute time ``t_trig`` (an ego that waits: nothing about it tells when to act).
``near``
    an imported OpenSCENARIO condition (:mod:`regen.driving.interop.importing`): the ego's
    straight-line distance to the point falls to ``distance`` [m] or below (a negative distance:
    never), or that distance over its speed to ``tta`` [s] or below (0: not used).

Time warp (:func:`warped_time`): until the trigger fires the actor holds its schedule and
states as they are just before ``t_trig``; once it fires at ``t_fire`` it runs them at
``t_trig + (t - t_fire)``. The template ego sets it off at ``t_trig`` (within one step), so the
scenario unfolds as scripted for it.

:func:`trigger_fired` and :func:`warped_time` are plain Python without imports: their source is
also written into the Scenic program (:func:`scenic_source`), so the simulation, the recorded
property states (:mod:`regen.driving.simulation.record`) and a policy's observations
(:mod:`regen.driving.testing.loop`) all use one implementation.
"""

from __future__ import annotations

import functools
import inspect
import math
from dataclasses import dataclass
from typing import Literal

from regen.driving.world.egos import MAX_BRAKE, EgoTemplate
from regen.driving.world.replay import replay_position

MIN_SPEED = 0.5  # below this ego speed [m/s] the time to arrival is not used
HOLD = 1e-3  # an untriggered actor holds its schedule this long [s] before t_trig
NEAR_TOL = 1e-3  # distance tolerance [m]: float noise must not delay a trigger by a step
TTA_TOL = 1e-4  # time-to-arrival tolerance [s]
TIME_TOL = 1e-6  # absolute-time tolerance [s]
LATE = 3.0  # an offset trigger fires at the latest this long after its template time [s]
STEP = 0.1  # the simulation step [s] (10 Hz) at which the template ego's speed is sampled
SLOWER_FRACTION = 0.5  # an ego_slower trigger fires below this fraction of the ego's event speed

Kind = Literal["approach", "ego_slower", "offset", "time", "near"]
KINDS: tuple[str, ...] = ("approach", "ego_slower", "offset", "time", "near")
# (kind, t_trig [s], px [m], py [m], ux, uy, distance [m], tta [s], below [m/s], offset [m],
#  rate [m/s], late [s])
Spec = tuple[str, float, float, float, float, float, float, float, float, float, float, float]


@dataclass(frozen=True, kw_only=True)
class Trigger:
    """When an actor's cause action starts (see the module docstring for the kinds)."""

    kind: Kind
    t: float  # template trigger time t_trig [s]
    x: float = 0.0  # reference point [m] (approach)
    y: float = 0.0  # [m]
    ux: float = 1.0  # unit direction of the ego's frame (approach, offset)
    uy: float = 0.0
    distance: float = 0.0  # fires within this distance [m] ahead of the ego (approach)
    tta: float = 0.0  # or within this time to arrival [s] (approach)
    below: float = 0.0  # fires when the ego is slower than this [m/s] (ego_slower)
    offset: float = 0.0  # fires when the actor is this far ahead of the ego [m] (offset)
    rate: float = 0.0  # how fast that offset changes in the template [m/s] (offset; sign: direction)
    late: float = 0.0  # fires at this time [s] at the latest (offset)

    @classmethod
    def of(cls, spec: Spec | tuple) -> Trigger:
        """The trigger of a :meth:`spec` tuple (as an imported actor stores it)."""
        kind, t, x, y, ux, uy, distance, tta, below, offset, rate, late = spec
        return cls(kind=kind, t=t, x=x, y=y, ux=ux, uy=uy, distance=distance, tta=tta, below=below,
                   offset=offset, rate=rate, late=late)

    def spec(self) -> Spec:
        """The tuple :func:`trigger_fired` and the Scenic program take."""
        return (self.kind, self.t, self.x, self.y, self.ux, self.uy, self.distance, self.tta, self.below,
                self.offset, self.rate, self.late)


def trigger_fired(spec, t, x, y, ego_speed, ax=None, ay=None):
    """Whether the trigger ``spec`` (:meth:`Trigger.spec`) fires at time ``t`` [s] for an ego
    at (``x``, ``y``) [m] moving at ``ego_speed`` [m/s], the actor at (``ax``, ``ay``) [m]."""
    kind, t_trig, px, py, ux, uy, near, tta, below, offset, rate, late = spec
    if kind == "time":
        return t >= t_trig - TIME_TOL
    if kind == "ego_slower":
        return ego_speed < below
    if kind == "offset":
        if t >= late - TIME_TOL:
            return True
        if ax is None:
            return False
        ahead = (ax - x) * ux + (ay - y) * uy  # [m] the actor is ahead of the ego along the frame
        return ahead >= offset - NEAR_TOL if rate >= 0.0 else ahead <= offset + NEAR_TOL
    if kind == "near":  # an imported condition (OpenSCENARIO): straight-line distance or time to the point
        d = math.hypot(px - x, py - y)
        return d <= near + NEAR_TOL or (tta > 0.0 and ego_speed > MIN_SPEED and d / ego_speed <= tta + TTA_TOL)
    dx, dy = px - x, py - y
    along = dx * ux + dy * uy  # [m] the point lies ahead of the ego along the frame
    gap = along + abs(dy * ux - dx * uy)  # [m] to go there: ahead + aside
    passed = along < 0.0
    return passed or gap <= near + NEAR_TOL or (ego_speed > MIN_SPEED and gap / ego_speed <= tta + TTA_TOL)


def warped_time(spec, t_fire, t, x, y, ego_speed, ax=None, ay=None):
    """``(t_fire, schedule time [s])`` of an actor at time ``t`` [s]: ``t_fire`` [s] is when its
    trigger ``spec`` fired (None: not yet; it is set here if it fires now, from the ego at
    (``x``, ``y``) [m] and ``ego_speed`` [m/s] and the actor at (``ax``, ``ay``) [m]); without
    a trigger (None) the time is ``t``."""
    if spec is None:
        return None, t
    if t_fire is None and trigger_fired(spec, t, x, y, ego_speed, ax, ay):
        t_fire = t
    if t_fire is None:
        return None, min(t, spec[1] - HOLD)
    return t_fire, spec[1] + (t - t_fire)


def fire_times(spec: Spec | None, times: list[float], xs: list[float], ys: list[float],
               speeds: list[float]) -> list[float]:
    """The schedule time [s] at each recorded step of an ego track (times [s], x, y [m], speed
    [m/s]), step by step as the simulation computes it."""
    t_fire, out = None, []
    for t, x, y, v in zip(times, xs, ys, speeds, strict=True):
        t_fire, tt = warped_time(spec, t_fire, t, x, y, v)
        out.append(tt)
    return out


@functools.cache
def scenic_source() -> str:
    """The constants and functions above as program text, for the Scenic program (read once per
    process: ``inspect.getsource`` tokenizes the module each time)."""
    consts = ("MIN_SPEED", "HOLD", "NEAR_TOL", "TTA_TOL", "TIME_TOL")
    lines = [f"{name} = {globals()[name]!r}" for name in consts]
    return "\n".join(lines) + "\n\n\n" + "\n\n".join(inspect.getsource(f) for f in (trigger_fired, warped_time))


def template_position(ego: EgoTemplate, t: float) -> tuple[float, float]:
    """Where [m] the template ego is at time ``t`` <= its event [s]: ``speed_event * t`` along its
    route (every moving template keeps its start speed until its event); a replayed ego is where
    its recording has it."""
    if ego.replay:
        return replay_position(ego, t)
    left = ego.speed_event * t
    route = ego.route
    for (ax, ay), (bx, by) in zip(route, route[1:], strict=False):
        seg = math.hypot(bx - ax, by - ay)
        if left <= seg and seg > 0:
            return ax + (bx - ax) * left / seg, ay + (by - ay) * left / seg
        left -= seg
    return route[-1]


def approach(ego: EgoTemplate, point: tuple[float, float], t: float) -> Trigger:
    """Fires as the ego comes near ``point`` [m]: at the distance and the time to arrival the
    template ego has at ``t`` [s]. ``time`` for an ego that waits, or that has passed the point
    by ``t`` (nearness means nothing then)."""
    if ego.speed_event <= 0.0:
        return Trigger(kind="time", t=t)
    ex, ey = template_position(ego, t)
    fr = ego.frame
    dx, dy = point[0] - ex, point[1] - ey
    if dx * fr.ux + dy * fr.uy < 0.0:
        return Trigger(kind="time", t=t)
    gap = dx * fr.ux + dy * fr.uy + abs(dy * fr.ux - dx * fr.uy)  # as trigger_fired measures it
    return Trigger(kind="approach", t=t, x=round(point[0], 4), y=round(point[1], 4), ux=fr.ux, uy=fr.uy,
                   distance=round(gap, 4), tta=round(gap / ego.speed_event, 4))


def offset_reached(ego: EgoTemplate, s: float, rate: float, t: float) -> Trigger:
    """Fires when the actor is as far ahead of the ego along the frame as it is in the template
    at ``t`` [s], where it is at ``s`` [m] along the frame, its offset changing at ``rate``
    [m/s]; at the latest :data:`LATE` after ``t``."""
    fr = ego.frame
    ex, ey = template_position(ego, t)
    s_ego = (ex - fr.ox) * fr.ux + (ey - fr.oy) * fr.uy
    return Trigger(kind="offset", t=t, ux=fr.ux, uy=fr.uy, offset=round(s - s_ego, 4), rate=round(rate, 4),
                   late=round(t + LATE, 4))


def ego_slower(ego: EgoTemplate) -> Trigger:
    """Fires when the ego brakes below :data:`SLOWER_FRACTION` of its event speed; ``t_trig``
    is the first step at which the template ego (full brake from its event) is that slow."""
    below = SLOWER_FRACTION * ego.speed_event
    steps = math.floor((ego.speed_event - below) / (MAX_BRAKE * STEP)) + 1
    return Trigger(kind="ego_slower", t=round(ego.t_event + steps * STEP, 4), below=round(below, 4))


def at_time(t: float) -> Trigger:
    """Fires at time ``t`` [s]."""
    return Trigger(kind="time", t=t)


__all__ = ["KINDS", "LATE", "Trigger", "approach", "at_time", "ego_slower", "fire_times", "offset_reached",
           "scenic_source", "template_position", "trigger_fired", "warped_time"]
