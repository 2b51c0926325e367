"""A recorded trajectory as the ego of every scenario of a run (paper 3.1: "a robot's behavior,
such as a motion trajectory").

:func:`recording` reads a CSV (:mod:`regen.driving.world.recorded`), detects the behavior class
and its event time, puts the path on a generated map and samples it once per simulation step:
the :class:`~regen.driving.world.setting.RecordedEgo` that a behavior carries in its parameters.
:func:`recorded_template` turns it into an ego template of the detected class whose ego *replays*
the samples exactly (the Scenic program sets its pose every step), whose event, event speed and
position are the recording's (so causes are placed and triggered relative to the detected event),
and whose FSM states are the class's with thresholds the recording can meet (a gentle stop is
still a stop: its braking threshold is 60 % of the recorded peak deceleration).

Placing an ego-start path (x forward, y left, metres from where the ego starts): a straight-road
class starts 150 m before the middle of the straight map, in the outer lane for a lane change to
the left and the inner lane otherwise; a stop after a turn is slid along its approach until it
lies on the T-junction's turning route (at most 2 m off, else a clear error). A path given in
map coordinates (``map=``) is taken as it is and checked to lie on that map's roads.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from regen.core.scenario import PredicateCall
from regen.driving.world.egos import EGO_TEMPLATES, EgoTemplate, template_for
from regen.driving.world.egos.base import Frame
from regen.driving.world.maps import geometry
from regen.driving.world.recorded import (
    CLASSES,
    Detection,
    Trajectory,
    detect,
    motion,
    read_trajectory,
)
from regen.driving.world.setting import DrivingParams, RecordedEgo
from regen.driving.world.states import State
from regen.errors import ConfigError

START_X = -150.0  # [m] where an ego-start path begins on the straight map (as the templates)
MARGIN = 5.0  # [m] kept from a road's end
FIT_TOLERANCE = 2.0  # [m] most a path may lie off a turning route
STRAIGHT = ("stop_abruptly", "slow_down", "drive_forward", "change_lane_left", "change_lane_right")
THRESHOLD_SHARE = 0.6  # a state's threshold is at most this share of the recording's own figure


def _route_distance(px: np.ndarray, py: np.ndarray, route: tuple[tuple[float, float], ...]) -> np.ndarray:
    """Distance [m] of each point to the polyline ``route``."""
    a = np.asarray(route[:-1], dtype=float)
    b = np.asarray(route[1:], dtype=float)
    ab = b - a
    ll = np.maximum((ab ** 2).sum(axis=1), 1e-9)
    p = np.stack([px, py], axis=1)[:, None, :]
    u = np.clip(((p - a) * ab).sum(axis=2) / ll, 0.0, 1.0)
    nearest = a + u[..., None] * ab
    return np.sqrt(((p - nearest) ** 2).sum(axis=2)).min(axis=1)


def _place(traj: Trajectory, det: Detection, map_name: str | None) -> tuple[str, float, float, str]:
    """(map, x offset, y offset, words): where an ego-start path goes on a generated map."""
    x, y = traj.x - traj.x[0], traj.y - traj.y[0]
    if map_name is not None:
        return map_name, 0.0, 0.0, f"given in the coordinates of the map {map_name}"
    if det.behavior in STRAIGHT:
        g = geometry("straight")
        lane = 1 if det.behavior == "change_lane_left" else 0
        x0 = min(START_X, g.x_max - MARGIN - float(x.max()))
        if x0 + float(x.min()) < g.x_min + MARGIN:
            raise ConfigError(f"trajectory {traj.source}: the path spans {float(x.max() - x.min()):.0f} m along "
                              f"its start heading; the straight map holds {g.x_max - g.x_min - 2 * MARGIN:.0f} m. "
                              "Cut it to the seconds around the behavior")
        return "straight", x0, g.lane_center_y(lane), (
            f"ego-start frame placed on the straight map at x = {x0:.0f} m in lane {lane} "
            f"({'outer' if lane else 'inner'} lane of its direction)")
    if det.behavior == "stop_after_turn":
        t = EGO_TEMPLATES["stop_after_turn"]
        x_start, y0 = t.route[0]
        best: tuple[float, float] | None = None
        for shift in np.arange(-60.0, 60.01, 0.5):
            err = float(_route_distance(x + x_start + shift, y + y0, t.route).max())
            if best is None or err < best[0]:
                best = (err, float(shift))
        assert best is not None
        if best[0] > FIT_TOLERANCE:
            raise ConfigError(f"trajectory {traj.source}: the path does not fit the turning route of the generated "
                              f"junction maps (it lies {best[0]:.1f} m off at best; they turn right from the west arm "
                              "with a 10 m radius). Give it in map coordinates with --map")
        return t.map, x_start + best[1], y0, (
            f"ego-start frame slid {best[1]:+.1f} m along the west arm of {t.map} onto its right turn "
            f"(at most {best[0]:.1f} m off the route)")
    raise ConfigError(f"trajectory {traj.source}: detected '{det.text}', which no ego template drives (causes "
                      "need the ego's states); record a stop, a slow-down, a start, a lane change, a stop "
                      "after a turn or a stop in an intersection")


def _check_on_map(map_name: str, xs: np.ndarray, ys: np.ndarray, source: str) -> None:
    g = geometry(map_name)
    if not g.junction and (xs.min() < g.x_min - 0.5 or xs.max() > g.x_max + 0.5):
        raise ConfigError(f"trajectory {source}: x runs from {xs.min():.0f} to {xs.max():.0f} m, beyond the map "
                          f"{map_name} ({g.x_min:.0f} to {g.x_max:.0f} m); check the frame (--map takes map "
                          "coordinates, without it x is metres ahead of the ego's start)")
    if not g.junction and (np.abs(ys) > g.road_half_width + 0.5).any():
        k = int(np.argmax(np.abs(ys)))
        raise ConfigError(f"trajectory {source}: y = {ys[k]:.1f} m is off the road of the map {map_name} "
                          f"(|y| <= {g.road_half_width:g} m)")


def recording(path: str | Path, *, map_name: str | None = None, dt: float = 0.1) -> tuple[RecordedEgo, Detection]:
    """The recorded ego of a trajectory file and what was detected in it (ConfigError with one
    line when the file is bad or the path fits no generated map)."""
    traj = read_trajectory(path)
    if map_name is not None:
        geometry(map_name)  # an unknown map names the choices
    det = detect(traj, map_name=map_name)
    if CLASSES[det.behavior][0] is None:
        _place(traj, det, None)  # raises: no template drives it
    map_used, x0, y0, words = _place(traj, det, map_name)
    base = 0.0 if map_name is not None else 1.0
    xs = traj.x - base * traj.x[0] + x0
    ys = traj.y - base * traj.y[0] + y0
    _check_on_map(map_used, xs, ys, traj.source)
    _, v, _, h = motion(traj)
    t = traj.t - traj.t[0]
    grid = np.arange(0.0, float(t[-1]) + 1e-9, dt)
    samples = [(round(float(a), 4), round(float(b), 4), round(float(c), 5), round(max(0.0, float(d)), 4))
               for a, b, c, d in zip(np.interp(grid, t, xs), np.interp(grid, t, ys), np.interp(grid, t, h),
                                     np.interp(grid, t, v), strict=True)]
    rec = RecordedEgo(source=Path(path).name, frame="map" if map_name else "ego_start", map=map_used,
                      detected=det.behavior, event_time=round(det.event_time - float(traj.t[0]), 3),
                      placement=words, evidence=list(det.evidence), dt=dt, samples=samples)
    return rec, det


def _along(frame: Frame, x: float, y: float) -> tuple[float, float]:
    """(s, d) of a point in ``frame`` [m]."""
    dx, dy = x - frame.ox, y - frame.oy
    return dx * frame.ux + dy * frame.uy, dy * frame.ux - dx * frame.uy


def _lane(frame: Frame, x: float, y: float) -> int:
    _, d = _along(frame, x, y)
    return max(0, int(round(-d / frame.lane_width - 0.5)))


class _Replayed:
    """Mixed into the detected class's template: its ego states, with thresholds and lanes the
    recording meets."""

    replay: tuple[tuple[float, float, float, float], ...]
    replay_dt: float
    frame: Frame
    t_event: float

    def _figures(self) -> tuple[float, float, int, int]:
        v = np.asarray([s[3] for s in self.replay])
        decel = -np.gradient(v, self.replay_dt)
        k = min(len(v) - 1, int(round(self.t_event / self.replay_dt)))
        before = float(v[: k + 1].max()) if k >= 0 else float(v[0])
        start, end = self.replay[0], self.replay[-1]
        return before, float(decel.max()), _lane(self.frame, start[0], start[1]), _lane(self.frame, end[0], end[1])

    def _fit(self, state: State, *, initial: bool) -> State:
        speed, peak, lane0, lane1 = self._figures()
        calls = []
        for c in state[1]:
            params = dict(c.params)
            if c.name == "moving" and "min_speed" in params:
                params["min_speed"] = min(float(params["min_speed"]), round(THRESHOLD_SHARE * speed, 1))
            if c.name == "braking" and "min_decel" in params:
                params["min_decel"] = min(float(params["min_decel"]), round(THRESHOLD_SHARE * peak, 1))
            if c.name == "in_lane" and "lane" in params:
                params["lane"] = lane0 if initial else lane1
            calls.append(PredicateCall(name=c.name, args=list(c.args), params=params, negate=c.negate))
        return state[0], calls

    def ego_states(self) -> tuple[State, list[State]]:
        initial, reactions = super().ego_states()  # type: ignore[misc]
        return self._fit(initial, initial=True), [self._fit(s, initial=False) for s in reactions]

    def prelude(self) -> list[State]:
        return [self._fit(s, initial=False) for s in super().prelude()]  # type: ignore[misc]


_CLASSES: dict[type, type] = {}


def _replayed_class(cls: type) -> type:
    if cls not in _CLASSES:
        _CLASSES[cls] = type(f"Replayed{cls.__name__}", (_Replayed, cls), {"__doc__": _Replayed.__doc__})
    return _CLASSES[cls]


def recorded_template(rec: RecordedEgo) -> EgoTemplate:
    """The ego template whose ego replays ``rec`` (see the module docstring)."""
    tid = CLASSES[rec.detected][0] if rec.detected in CLASSES else None
    if tid is None or tid not in EGO_TEMPLATES:
        raise ConfigError(f"recorded behavior class {rec.detected!r} has no ego template")
    base = EGO_TEMPLATES[tid]
    base = base if rec.map == base.map else base.on_map(rec.map)
    samples = tuple(tuple(s) for s in rec.samples)
    if len(samples) < 2:
        raise ConfigError(f"recorded trajectory {rec.source} has fewer than two samples")
    route = [samples[0][:2]]
    for x, y, _, _ in samples[1:]:
        if math.hypot(x - route[-1][0], y - route[-1][1]) >= 1.0:
            route.append((x, y))
    if len(route) < 2:
        route.append(samples[-1][:2] if samples[-1][:2] != route[0] else (route[0][0] + 1.0, route[0][1]))
    dt = rec.dt
    k_event = min(len(samples) - 1, int(round(rec.event_time / dt)))
    v = [s[3] for s in samples]
    step = max(1, int(round(0.5 / dt)))
    schedule = tuple((round(k * dt, 3), round(v[k], 3), 1.0 if k + step < len(v) and v[k] - v[k + step] > 1.0 else 0.0)
                     for k in range(0, len(v), step))
    frame = base.frame
    xe, ye = samples[k_event][:2]
    cls = _replayed_class(type(base))
    fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    fields.update(
        description=f"replays the recorded trajectory {rec.source} ({CLASSES[rec.detected][1].removeprefix('the ')})",
        route=tuple(route), speed0=samples[0][3], schedule=schedule, t_event=rec.event_time,
        duration=round(len(samples) * dt + 1.0, 3), s_event=_along(frame, xe, ye)[0],
        speed_event=max(v[: k_event + 1]) if rec.detected != "drive_forward" else 0.0,
        ego_lane=_lane(frame, xe, ye), stops=v[-1] < 0.5, s_end=_along(frame, *samples[-1][:2])[0],
        junction_maps=(), replay=samples, replay_dt=dt)
    return cls(**fields)


def replay_position(ego: EgoTemplate, t: float) -> tuple[float, float]:
    """Where [m] a replayed ego is at time ``t`` [s] (held at the ends)."""
    k = max(0.0, t / ego.replay_dt)
    i = min(int(k), len(ego.replay) - 1)
    j = min(i + 1, len(ego.replay) - 1)
    f = k - int(k) if j > i else 0.0
    (x0, y0, _, _), (x1, y1, _, _) = ego.replay[i], ego.replay[j]
    return x0 + (x1 - x0) * f, y0 + (y1 - y0) * f




def ego_template(text: str, params: DrivingParams) -> EgoTemplate:
    """The ego template of a driving behavior: the recorded one it replays, else the template
    it names or its text describes."""
    if params.recorded is not None:
        return recorded_template(params.recorded)
    return template_for(text, params.ego_template)


__all__ = ["ego_template", "recorded_template", "recording", "replay_position"]
