"""Turn what the Newtonian simulation recorded into a Trace, adding the project layer.

The Newtonian model knows poses and speeds only. This module adds, per step: map facts (lane,
on road, on sidewalk, in junction) from the analytic map geometry, and property states that
the model lacks: scheduled states (traffic lights, sirens, doors, hazard lights, sensor
signals), brake lights derived from deceleration, and what a sensor makes the ego perceive (the
GNSS error and perceived position, the camera's lost view: regen.driving.world.sensing).
Scheduled states run on the actor's warped clock (:mod:`regen.driving.world.triggers`), computed
step by step from the recorded ego as the Scenic program computed it, so a light turns red when
the simulated actors saw it turn.
"""

from __future__ import annotations

import math

import numpy as np

from regen.core.trace import ActorTrack, Trace
from regen.driving.simulation.run import RawRun
from regen.driving.world.egos import JUNCTION_CX
from regen.driving.world.maps import MapGeometry
from regen.driving.world.plan import ActorPlan
from regen.driving.world.sensing import BASE, ERROR_STATE, effect_of, perceived_error
from regen.driving.world.triggers import fire_times

BRAKE_LIGHT_DECEL = 1.0  # deceleration above which brake lights are lit [m/s^2]


def map_facts(geo: MapGeometry, x: float, y: float) -> tuple[int | None, bool, bool, bool]:
    """(lane, on_road, on_sidewalk, in_junction) of a point on the map."""
    half = geo.road_half_width
    walk = half + geo.sidewalk_width
    if not geo.junction:
        if abs(y) < half:
            return (int(-y // geo.lane_width) if y < 0 else -int(y // geo.lane_width) - 1), True, False, False
        return None, False, abs(y) < walk, False
    dx, r = x - JUNCTION_CX, geo.junction_radius
    if abs(dx) < r and abs(y) < r:
        return None, True, False, True
    if abs(dx) >= r and abs(y) < walk:  # horizontal arms
        if abs(y) < half:
            return (0 if y < 0 else -1), True, False, False
        return None, False, True, False
    if abs(y) >= r and abs(dx) < walk:  # vertical arms: north-bound lane is 0
        if abs(dx) < half:
            return (0 if dx > 0 else -1), True, False, False
        return None, False, True, False
    return None, False, False, False


def _scheduled(schedule: list[tuple[float, str]], times: list[float]) -> list[str | None]:
    """The value of ``schedule`` [(t_from [s], value)] at each of ``times`` [s] (schedule time)."""
    out: list[str | None] = []
    for t in times:
        val = None
        for t_from, v in schedule:
            if t >= t_from - 1e-9:
                val = v
        out.append(val)
    return out


def _perception(p: ActorPlan, states: dict[str, list], clock: list[float], xs, ys, hs) -> None:
    """A sensor's perceived error at every step (regen.driving.world.sensing, the function the
    ego reacted to in the simulation) and, for GNSS, the position the ego perceives."""
    for key, error_key in ERROR_STATE.items():
        if key not in states:
            continue
        eff = effect_of(p)
        base = BASE[key]
        errors = ([perceived_error(c - eff.t_switch, eff.rate, eff.magnitude, base) for c in clock]
                  if eff is not None else [base] * len(clock))
        states[error_key] = [round(e, 4) for e in errors]
        if key == "gnss_signal":  # off to the ego's left
            states["perceived_x"] = [round(x - math.sin(h) * e, 4) for x, h, e in zip(xs, hs, errors, strict=True)]
            states["perceived_y"] = [round(y + math.cos(h) * e, 4) for y, h, e in zip(ys, hs, errors, strict=True)]


def build_trace(run: RawRun, plans: list[ActorPlan], geo: MapGeometry, *, map_path: str,
                seed: int = 0, meta: dict | None = None) -> Trace:
    """The Trace of a run: every plan gets a track (sensors ride on the actor they attach to)."""
    actors: dict[str, ActorTrack] = {}
    n = len(run.times)
    ego = (run.x["ego"], run.y["ego"], run.speed["ego"]) if "ego" in run.x else None
    for p in plans:
        src = p.attach_to if p.kind == "sensor" and p.attach_to in run.x else p.name
        if src in run.x:
            xs, ys, hs, vs = run.x[src], run.y[src], run.heading[src], run.speed[src]
        else:  # a state-only object that Scenic does not hold: it stays where it was placed
            xs, ys, hs, vs = [p.x] * n, [p.y] * n, [p.heading] * n, [0.0] * n
        hs = [math.atan2(math.sin(h), math.cos(h)) for h in hs]
        facts = [map_facts(geo, x, y) for x, y in zip(xs, ys, strict=True)]
        states: dict[str, list] = {
            "lane": [f[0] for f in facts],
            "on_road": [f[1] for f in facts],
            "on_sidewalk": [f[2] for f in facts],
            "in_junction": [f[3] for f in facts],
        }
        clock = run.times
        if p.states:
            clock = (fire_times(p.trigger.spec(), run.times, *ego) if p.trigger is not None and ego
                     else run.times)
            for key, sched in p.states.items():
                states[key] = _scheduled(sched, clock)
        if p.cls == "Car" and p.kind != "object":
            acc = np.gradient(np.asarray(vs), run.dt) if n >= 2 else np.zeros(n)
            broken = p.states.get("brake_lights", [(0.0, "")])[-1][1] == "broken"
            states["brake_lights"] = ["off" if broken or a > -BRAKE_LIGHT_DECEL else "on" for a in acc]
        _perception(p, states, clock, xs, ys, hs)
        actors[p.name] = ActorTrack(asset=p.asset, kind=p.kind, length=p.length, width=p.width,
                                    height=p.height, x=list(xs), y=list(ys), heading=hs,
                                    speed=list(vs), states=states)
    for track in actors.values():  # the pictures draw the perceived position on the ego
        if "perceived_x" in track.states and "ego" in actors and track.x:
            actors["ego"].states["gnss_x"] = track.states["perceived_x"]
            actors["ego"].states["gnss_y"] = track.states["perceived_y"]
    info = {"simulator": "scenic-newtonian", "map": geo.name, "map_path": str(map_path)}
    info.update(meta or {})
    return Trace(dt=run.dt, times=list(run.times), actors=actors, meta=info)
