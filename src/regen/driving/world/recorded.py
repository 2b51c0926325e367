"""A recorded ego trajectory: read it, check it, and tell which behavior it shows and when.

The paper's input is "a robot's behavior, such as a motion trajectory". A trajectory file is a
CSV with a header: ``t,x,y`` [s, m, m] and optionally ``heading`` [rad, counter-clockwise from
+x] and ``speed`` [m/s]. Coordinates are either an **ego-start frame** (metres, the origin where
the ego starts, x forward along its first heading, y to its left) or the coordinates of one of
the generated maps (``map=``: ``straight``, ``four_way``, ``t_junction``), which is what tells a
stop in an intersection from any other stop.

:func:`detect` classifies the kinematics into the ego templates' behaviors (stop abruptly, slow
down, drive off from a stop, change lane left or right, stop after a turn, stop in an
intersection) or a plain turn left or right, with the event time (when the reaction starts) and
the evidence in words. Bad files raise ConfigError with one line naming the row and the fix.
Imports: numpy and this domain's map constants only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from regen.driving.world.egos.base import JUNCTION_CX
from regen.driving.world.maps import JUNCTION_RADIUS
from regen.errors import ConfigError
from regen.promises.files import csv_rows, label, shown

MAX_ABS_ACCEL = 12.0  # [m/s^2] beyond any car's braking or throttle, after smoothing
MAX_ABS_VALUE = 1e12  # [m, s, rad, m/s] beyond any recording (a Unix time in seconds is 1.7e9)
MIN_STEP = 1e-3  # [s] samples closer than this (over 1 kHz) are a unit mistake, not a recording
MAX_DURATION = 600.0  # [s] a behavior takes seconds; a longer recording is cut to it first
STILL = 0.5  # [m/s] below this the ego stands still
JUNCTION_MAPS = ("four_way", "t_junction")

#: class -> (ego template id or None when no template drives it, behavior text)
CLASSES: dict[str, tuple[str | None, str]] = {
    "stop_abruptly": ("stop_abruptly", "the ego-vehicle stops abruptly while driving forward"),
    "slow_down": ("slow_down", "the ego-vehicle slows down"),
    "drive_forward": ("drive_forward", "the ego-vehicle drives forward from stationary"),
    "change_lane_left": ("change_lane", "the ego-vehicle changes lanes to the left while driving forward"),
    "change_lane_right": ("change_lane", "the ego-vehicle changes lanes to the right while driving forward"),
    "stop_after_turn": ("stop_after_turn", "the ego-vehicle stops abruptly after a turn"),
    "stop_in_intersection": ("stop_in_intersection", "the ego-vehicle stops abruptly in an intersection"),
    "turn_left": (None, "the ego-vehicle turns left"),
    "turn_right": (None, "the ego-vehicle turns right"),
}


@dataclass
class Trajectory:
    t: np.ndarray  # [s], strictly increasing
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    heading: np.ndarray | None = None  # [rad]
    speed: np.ndarray | None = None  # [m/s]
    source: str = ""


@dataclass
class Detection:
    behavior: str  # a key of CLASSES
    template: str | None  # the ego template that drives it (None: a plain turn)
    text: str  # the behavior in words
    event_time: float  # [s] when the reaction starts
    evidence: list[str] = field(default_factory=list)


_GIVE = "give a CSV file with a header t,x,y[,heading,speed] and one row per sample"


def _bad(source: str, what: str) -> ConfigError:
    return ConfigError(f"trajectory {source}: {what}")


def read_trajectory(path: str | Path) -> Trajectory:
    """The trajectory in a CSV file (UTF-8, with or without a spreadsheet's byte-order mark);
    ConfigError with one line for every way it can be wrong. Rows are counted as the file's
    lines, as a spreadsheet numbers them."""
    name = label(path)
    rows = csv_rows(path, what="trajectory", give=_GIVE)
    if not rows:
        raise _bad(name, "is empty; give a CSV with a header t,x,y[,heading,speed] and one row per sample")
    head = [c.strip().lower() for c in rows[0][1]]
    missing = [c for c in ("t", "x", "y") if c not in head]
    if missing:
        raise _bad(name, f"has no column {', '.join(missing)} (its header: {shown(','.join(head))}); the header "
                         "must name t,x,y and may add heading,speed")
    body = rows[1:]
    if len(body) < 2:
        raise _bad(name, f"has {len(body)} row(s); a behavior needs at least two samples (10 Hz or faster)")
    cols: dict[str, list[float]] = {c: [] for c in head if c in ("t", "x", "y", "heading", "speed")}
    for i, r in body:
        if len(r) < len(head):
            raise _bad(name, f"row {i} has {len(r)} values, the header {len(head)}")
        for c in cols:
            raw = r[head.index(c)].strip()
            try:
                v = float(raw)
            except ValueError:
                raise _bad(name, f"row {i}: {c} = {shown(raw)} is not a number") from None
            number = raw if len(raw) <= 40 else raw[:40] + "..."  # float() took it: digits, no control characters
            if not math.isfinite(v):
                raise _bad(name, f"row {i}: {c} = {number} is not finite (NaN or inf); remove or fill the sample")
            if abs(v) > MAX_ABS_VALUE:
                raise _bad(name, f"row {i}: {c} = {number} is beyond {MAX_ABS_VALUE:g}; give metres, seconds, "
                                 "radians and m/s")
            cols[c].append(v)
    t = np.asarray(cols["t"])
    dt = np.diff(t)
    if (dt <= 0).any():
        k = int(np.flatnonzero(dt <= 0)[0]) + 1
        raise _bad(name, f"time does not increase at row {body[k][0]} (t = {t[k]:g} after {t[k - 1]:g}); sort the "
                         "rows by t and remove repeated samples")
    if (dt < MIN_STEP).any():
        k = int(np.flatnonzero(dt < MIN_STEP)[0]) + 1
        raise _bad(name, f"row {body[k][0]} is {dt[k - 1]:g} s after the one before; samples must be at least "
                         f"{MIN_STEP:g} s apart (t in seconds)")
    if t[-1] - t[0] > MAX_DURATION:
        raise _bad(name, f"spans {t[-1] - t[0]:g} s; a behavior takes seconds: cut the recording to at most "
                         f"{MAX_DURATION:g} s around it (t in seconds)")
    traj = Trajectory(t=t, x=np.asarray(cols["x"]), y=np.asarray(cols["y"]),
                      heading=np.asarray(cols["heading"]) if "heading" in cols else None,
                      speed=np.asarray(cols["speed"]) if "speed" in cols else None, source=name)
    _, v, a = _kinematics(traj)
    if np.abs(a).max() > MAX_ABS_ACCEL:
        k = int(np.argmax(np.abs(a)))
        raise _bad(name, f"an acceleration of {a[k]:.1f} m/s^2 near t = {t[k]:.2f} s is beyond any car "
                         f"(|a| <= {MAX_ABS_ACCEL:g}); check the units (metres, seconds) and jumps in x, y")
    return traj


def _smooth(values: np.ndarray, t: np.ndarray, window: float, *, trend: bool = False) -> np.ndarray:
    """Centred moving average over ``window`` seconds (the samples' own spacing); ``trend``:
    the ends are extended along their slope instead of held (a moving car's positions)."""
    step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    k = max(1, int(round(window / step)))
    if k <= 1 or len(values) < k:
        return values.astype(float)
    widths = (k // 2, k - 1 - k // 2)
    pad = (np.pad(values.astype(float), widths, mode="reflect", reflect_type="odd") if trend
           else np.pad(values.astype(float), widths, mode="edge"))
    return np.convolve(pad, np.ones(k) / k, mode="valid")


def _kinematics(traj: Trajectory, *, trend: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(smoothed x/y as an (n, 2) array, speed [m/s], acceleration along the path [m/s^2]);
    ends held (the detector's thresholds were measured so) or, with ``trend``, extended along
    their slope (:func:`motion`)."""
    t = traj.t
    xs, ys = _smooth(traj.x, t, 0.6, trend=trend), _smooth(traj.y, t, 0.6, trend=trend)
    if traj.speed is not None:
        v = _smooth(traj.speed, t, 0.3, trend=trend)
    else:
        v = _smooth(np.hypot(np.gradient(xs, t), np.gradient(ys, t)), t, 0.6, trend=trend)
    if trend:
        v = np.maximum(v, 0.0)
    a = _smooth(np.gradient(v, t), t, 0.6)
    return np.stack([xs, ys], axis=1), v, a


def _course(xy: np.ndarray, *, first: bool, metres: float = 20.0) -> float | None:
    """Direction of travel [rad] over the first (or last) ``metres`` of the path: a chord, so
    position noise of a few centimetres does not turn it."""
    pts = xy if first else xy[::-1]
    d = np.hypot(pts[:, 0] - pts[0, 0], pts[:, 1] - pts[0, 1])
    far = np.flatnonzero(d >= metres)
    if not far.size:
        return None
    seg = pts[: int(far[0]) + 1]
    # the principal direction of those points (a least-squares line), pointing the way travelled
    centred = seg - seg.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    u = vt[0] if np.dot(vt[0], seg[-1] - seg[0]) > 0 else -vt[0]
    return math.atan2(u[1], u[0]) if first else math.atan2(-u[1], -u[0])


def _headings(traj: Trajectory, xy: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Heading [rad], unwrapped; from the file where given, else from the motion (held while still)."""
    if traj.heading is not None:
        return np.unwrap(traj.heading)
    d = np.gradient(xy, traj.t, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    moving = v > 1.0
    if not moving.any():
        return np.zeros(len(v))
    first = int(np.flatnonzero(moving)[0])
    for k in range(len(h)):  # hold the last heading while nearly still
        if k < first:
            h[k] = h[first]
        elif not moving[k]:
            h[k] = h[k - 1]
    return np.unwrap(h)


def _onset(t: np.ndarray, signal: np.ndarray, threshold: float, *, after: float = -math.inf,
           sustained: float = 0.3) -> float | None:
    """First time ``signal`` exceeds ``threshold`` for ``sustained`` seconds (at or after
    ``after``), refined to the start of that rise: back to where it was under half of it
    (at most 1.5 s back)."""
    over = (signal > threshold) & (t >= after)
    step = float(np.median(np.diff(t)))
    need = max(1, int(round(sustained / step)))
    run = np.convolve(over.astype(int), np.ones(need, dtype=int), mode="full")[need - 1:len(over) + need - 1]
    idx = np.flatnonzero(run >= need)
    if not idx.size:
        return None
    k = int(idx[0])
    k0 = k
    while k > 0 and signal[k - 1] > threshold / 2 and t[k0] - t[k - 1] <= 1.5:
        k -= 1
    return float(t[k])


def motion(traj: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(smoothed x/y (n, 2) [m], speed [m/s], acceleration [m/s^2], unwrapped heading [rad]),
    the ends extended along their slope (a car that is moving at the first sample has its speed
    there), for replaying the trajectory."""
    xy, v, a = _kinematics(traj, trend=True)
    return xy, v, a, _headings(traj, xy, v)


def detect(traj: Trajectory, *, map_name: str | None = None) -> Detection:
    """The behavior the trajectory shows and when its reaction starts (see the module docstring)."""
    t = traj.t
    xy, v, a = _kinematics(traj)
    h = _headings(traj, xy, v)
    n = len(t)
    edge = max(1, int(round(0.5 / float(np.median(np.diff(t))))))
    v0, v_end = float(np.median(v[:edge])), float(np.median(v[-edge:]))
    c_first, c_last = _course(xy, first=True), _course(xy, first=False)
    if c_first is not None and c_last is not None and traj.heading is None:
        turn = math.remainder(c_last - c_first, math.tau)  # chords: immune to centimetre noise
        h0 = c_first
    else:
        turn, h0 = float(h[-1] - h[0]), float(h[0])
    shown = motion(traj)[1]  # speeds with the ends extended: what a reader expects at the ends
    ev = [f"speed {float(np.median(shown[:edge])):.1f} -> {float(np.median(shown[-edge:])):.1f} m/s",
          f"heading change {math.degrees(turn):+.0f} deg"]
    decel = -a

    def result(cls: str, when: float | None) -> Detection:
        template, text = CLASSES[cls]
        return Detection(cls, template, text, float(when if when is not None else t[0]), ev)

    if v0 < STILL and v_end > 2.0:
        # from rest: the first metre takes 2 m / v at constant acceleration, so the start is
        # then; robust to position noise that makes a standing car seem to creep
        d = np.hypot(xy[:, 0] - xy[0, 0], xy[:, 1] - xy[0, 1])
        k = int(np.flatnonzero(d >= 1.0)[0]) if (d >= 1.0).any() else 0
        return result("drive_forward", float(t[k]) - 2.0 / max(float(v[k]), 0.5))
    if abs(turn) > math.radians(45):
        side = "left" if turn > 0 else "right"
        ev.append(f"turned {side}")
        if v_end < STILL:
            # the stop after the turn: braking that starts once the heading has settled
            settled = float(t[int(np.flatnonzero(np.abs(h - h[-1]) > math.radians(10))[-1])]) \
                if (np.abs(h - h[-1]) > math.radians(10)).any() else float(t[0])
            return result("stop_after_turn", _onset(t, decel, 1.5, after=settled))
        return result(f"turn_{side}", _onset(t, np.abs(np.gradient(h, t)), math.radians(5)))
    # lateral offset from the first heading's line
    c, s = math.cos(h0), math.sin(h0)
    lateral = _smooth(-(xy[:, 0] - xy[0, 0]) * s + (xy[:, 1] - xy[0, 1]) * c, t, 1.0)
    base = float(np.median(lateral[:edge]))
    lateral = lateral - base
    shift = float(np.median(lateral[-edge:]))
    if abs(shift) > 2.0 and v_end > STILL:
        side = "left" if shift > 0 else "right"
        ev.append(f"lateral shift {shift:+.1f} m")
        return result(f"change_lane_{side}", _onset(t, np.abs(lateral), 0.5))
    if v0 > 2.0 and v_end < STILL:
        when = _onset(t, decel, 1.5)
        k = int(np.flatnonzero(v < STILL)[0]) if (v < STILL).any() else n - 1
        if map_name in JUNCTION_MAPS and math.hypot(xy[k, 0] - JUNCTION_CX, xy[k, 1]) <= JUNCTION_RADIUS + 2.0:
            ev.append(f"stopped in the junction of {map_name}")
            return result("stop_in_intersection", when)
        return result("stop_abruptly", when)
    if v0 > 2.0 and v_end < 0.8 * v0:
        return result("slow_down", _onset(t, decel, 0.5))
    raise ConfigError(f"trajectory {traj.source}: no behavior class fits ({'; '.join(ev)}); the ego must stop, "
                      "slow down, drive off from a stop, change lane or turn")


__all__ = ["CLASSES", "Detection", "Trajectory", "detect", "motion", "read_trajectory"]
