"""What a trace says about one actor's motion around a moment: its pose and speed at a step,
the change of its speed, heading and lateral place after the step (in the frame of a reference
pose). Every dataset label, check and answer is read from these numbers, never from a model."""

from __future__ import annotations

import math
from dataclasses import dataclass

from regen.core.trace import ActorTrack, Trace

STILL = 0.5  # [m/s] at or below this an actor counts as stopped
LATERAL = 1.5  # [m] sideways displacement that counts as a lane change (about half a lane)
TURN = math.radians(30.0)  # heading change that counts as a turn [rad]
SPEED_CHANGE = 2.0  # [m/s] a speed change smaller than this is keeping the speed


def step_at(trace: Trace, t: float) -> int:
    """The trace step nearest to ``t`` [s], clamped to the trace."""
    times = trace.times
    if not times:
        raise ValueError("the trace has no steps")
    return min(range(len(times)), key=lambda i: (abs(times[i] - t), i))


def speeds(trace: Trace, a: ActorTrack) -> list[float]:
    """Speed per step [m/s]: the recorded one, else from the positions."""
    if a.speed:
        return [float(v) for v in a.speed]
    out = [0.0]
    for i in range(1, len(a.x)):
        out.append(math.hypot(a.x[i] - a.x[i - 1], a.y[i] - a.y[i - 1]) / (trace.dt or 1.0))
    if len(out) > 1:
        out[0] = out[1]
    return out[: len(a.x)]


def headings(a: ActorTrack) -> list[float]:
    """Heading per step [rad]: the recorded one, else the direction of travel (held when still)."""
    if a.heading:
        return [float(h) for h in a.heading]
    out: list[float] = []
    last = 0.0
    for i in range(len(a.x)):
        j = min(i + 1, len(a.x) - 1)
        k = j - 1 if j > 0 else 0
        dx, dy = a.x[j] - a.x[k], a.y[j] - a.y[k]
        if math.hypot(dx, dy) > 1e-6:
            last = math.atan2(dy, dx)
        out.append(last)
    return out


def wrap(angle: float) -> float:
    """``angle`` [rad] in (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def relative(ox: float, oy: float, heading: float, x: float, y: float) -> tuple[float, float]:
    """(along, left) [m] of the point (x, y) in the frame at (ox, oy) facing ``heading`` [rad]."""
    dx, dy = x - ox, y - oy
    c, s = math.cos(heading), math.sin(heading)
    return dx * c + dy * s, -dx * s + dy * c


@dataclass(frozen=True)
class After:
    """An actor's motion from step ``i`` to the end of the trace (or ``horizon`` seconds)."""

    t: float  # [s] the moment
    t_end: float  # [s] the last step looked at
    speed: float  # [m/s] at the moment
    before: float  # [m/s] fastest in the second before the moment
    slowest: float  # [m/s] after the moment
    fastest: float  # [m/s] after the moment
    final: float  # [m/s] at the last step looked at
    stops_at: float | None  # [s] first time at or below STILL after the moment
    left: float  # [m] sideways displacement to the left (negative: right) of the heading at the moment, largest in size
    along: float  # [m] distance travelled along the heading at the moment, at the end
    turned: float  # [rad] heading change (counter-clockwise positive) at the end


def reference_heading(a: ActorTrack, h: list[float], first: int, i: int) -> float:
    """The direction the actor came from over steps ``first``..``i`` (a recorded heading at the
    moment may already lean into a lane change that starts there); its heading at ``i`` when it
    moved less than a metre."""
    dx, dy = a.x[i] - a.x[first], a.y[i] - a.y[first]
    return math.atan2(dy, dx) if math.hypot(dx, dy) >= 1.0 else h[i]


def after(trace: Trace, name: str, t: float, horizon: float | None = None) -> After:
    """How actor ``name`` moves after ``t`` [s] (to the end, or ``horizon`` [s] after ``t``)."""
    a = trace.actors[name]
    i = step_at(trace, t)
    v, h = speeds(trace, a), headings(a)
    end = len(trace.times) - 1 if horizon is None else step_at(trace, trace.times[i] + horizon)
    end = max(end, i)
    first = step_at(trace, trace.times[i] - 1.0)
    rest = range(i, end + 1)
    ref = reference_heading(a, h, first, i)
    lefts = [relative(a.x[i], a.y[i], ref, a.x[k], a.y[k])[1] for k in rest]
    left = max(lefts, key=lambda d: (abs(d), d))
    along = relative(a.x[i], a.y[i], ref, a.x[end], a.y[end])[0]
    stops = next((trace.times[k] for k in rest if v[k] <= STILL), None)
    return After(t=float(trace.times[i]), t_end=float(trace.times[end]), speed=v[i],
                 before=max(v[first: i + 1]), slowest=min(v[k] for k in rest),
                 fastest=max(v[k] for k in rest), final=v[end], stops_at=stops, left=left, along=along,
                 turned=wrap(h[end] - ref))


__all__ = ["After", "LATERAL", "SPEED_CHANGE", "STILL", "TURN", "after", "headings", "relative", "speeds",
           "step_at", "wrap"]
