"""Play a read OpenSCENARIO storyboard kinematically, step by step, as a player would.

Each entity starts at its teleport pose and speed and drives straight along its heading; an
event starts when one of its condition groups holds (all conditions of the group), and its
actions then set the motion: a trajectory puts the entity where the polyline has it at that time
(position mode; after its last vertex it goes on straight at its last speed), a speed action
changes the speed with its dynamics (step, linear, cubic or sinusoidal over time, distance or
rate), a lane change moves it sideways by lanes of :data:`LANE_WIDTH` with its dynamics
(positive: to the left of its heading). A later event of the same entity overrides its
earlier motion (priority ``override``).

The result is every entity's pose at every step (:class:`Played`): the ego's samples become the
recording it replays, and each other actor keeps its motion from the start (events at time 0)
and its cause event (the one a condition starts), which the simulation replays from where the
ego sets the condition off (:class:`~regen.driving.world.setting.ImportedActor`).

Conditions are measured as OpenSCENARIO defines them for a world position: straight-line
distance, time to reach it at the current speed, the entity's speed, and the longitudinal offset
along the ego's starting heading (documented in docs/interop.md). Imports: the reader's data
and the trigger functions of this domain's world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from regen.driving.interop.xosc_data import Action, Condition, Event, ParsedScenario
from regen.driving.world.maps import LANE_WIDTH
from regen.driving.world.triggers import MIN_SPEED, trigger_fired
from regen.errors import ConfigError

TOL = 1e-6
Pose = tuple[float, float, float, float]  # x [m], y [m], heading [rad from +x], speed [m/s]


def _shape(shape: str, tau: float) -> float:
    tau = min(1.0, max(0.0, tau))
    if shape == "step":
        return 1.0
    if shape == "linear":
        return tau
    if shape == "cubic":
        return tau * tau * (3.0 - 2.0 * tau)
    if shape == "sinusoidal":
        return 0.5 - 0.5 * math.cos(math.pi * tau)
    raise ConfigError(f"dynamics shape {shape!r} is not read; use step, linear, cubic or sinusoidal")


def _holds(value: float, rule: str, ref: float) -> bool:
    return {"lessThan": value < ref, "lessOrEqual": value <= ref + TOL, "greaterThan": value > ref,
            "greaterOrEqual": value >= ref - TOL, "equalTo": abs(value - ref) <= 1e-3}[rule]


@dataclass
class _Motion:
    """What moves an entity now: a trajectory, or straight driving with speed and lane changes."""

    traj: Action | None = None
    t_traj: float = 0.0
    speed: Action | None = None
    t_speed: float = 0.0
    v_from: float = 0.0
    s_speed: float = 0.0  # [m] travelled since the speed action started (distance dynamics)
    lane: Action | None = None
    t_lane: float = 0.0
    s_lane: float = 0.0  # [m] travelled along the lane change
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)  # pose where the lane change started
    d_from: float = 0.0


class Mover:
    """One entity's kinematic state."""

    def __init__(self, x: float, y: float, h: float, v: float) -> None:
        self.x, self.y, self.h, self.v = x, y, h, v
        self.m = _Motion()

    @property
    def pose(self) -> Pose:
        return (self.x, self.y, self.h, self.v)

    def start(self, action: Action, t: float) -> None:
        if action.kind in ("signal", "state"):  # switches a signal or a state, moves nothing
            return
        if action.kind == "trajectory":
            self.m = _Motion(traj=action, t_traj=t)
        elif action.kind == "speed":
            self.m.traj = None
            self.m.speed, self.m.t_speed, self.m.v_from, self.m.s_speed = action, t, self.v, 0.0
        else:
            self.m.traj = None
            self.m.lane, self.m.t_lane, self.m.s_lane = action, t, 0.0
            self.m.origin, self.m.d_from = (self.x, self.y, self.h), 0.0

    def _on_trajectory(self, t: float) -> None:
        a, t0 = self.m.traj, self.m.t_traj
        assert a is not None
        tt = t - t0 if a.relative else t
        vs = a.vertices
        if tt <= vs[0][0]:
            _, self.x, self.y, self.h = vs[0]
            self.v = math.hypot(vs[1][1] - vs[0][1], vs[1][2] - vs[0][2]) / (vs[1][0] - vs[0][0])
            return
        for (ta, xa, ya, ha), (tb, xb, yb, hb) in zip(vs, vs[1:], strict=False):
            if tt <= tb:
                u = (tt - ta) / (tb - ta)
                self.x, self.y = xa + u * (xb - xa), ya + u * (yb - ya)
                dh = (hb - ha + math.pi) % (2 * math.pi) - math.pi
                self.h = ha + u * dh
                self.v = math.hypot(xb - xa, yb - ya) / (tb - ta)
                return
        # past the last vertex: on straight at the last speed
        (ta, xa, ya, _), (tb, xb, yb, hb) = vs[-2], vs[-1]
        self.v = math.hypot(xb - xa, yb - ya) / (tb - ta)
        ahead = (tt - tb) * self.v
        self.h = hb
        self.x, self.y = xb + ahead * math.cos(hb), yb + ahead * math.sin(hb)

    def _speed_now(self, t: float, dt: float) -> float:
        a = self.m.speed
        if a is None:
            return self.v
        dv = a.target - self.m.v_from
        if a.shape == "step" or abs(dv) < TOL:
            return a.target
        if a.dimension == "rate":
            dur = abs(dv) / max(a.amount, TOL)
        elif a.dimension == "distance":
            dur = 2.0 * a.amount / max(self.m.v_from + a.target, TOL)
        else:
            dur = a.amount
        tau = (t - self.m.t_speed) / dur if dur > 0 else 1.0
        return self.m.v_from + dv * _shape(a.shape, tau)

    def advance(self, t: float, dt: float) -> None:
        """The state at ``t`` + ``dt`` [s]."""
        if self.m.traj is not None:
            self._on_trajectory(t + dt)
            return
        v_next = max(0.0, self._speed_now(t + dt, dt))
        step = 0.5 * (self.v + v_next) * dt
        self.v = v_next
        lane = self.m.lane
        if lane is None:
            self.x += step * math.cos(self.h)
            self.y += step * math.sin(self.h)
            return
        self.m.s_lane += step
        dur = lane.amount if lane.dimension == "time" else (lane.amount / max(self.v, MIN_SPEED))
        tau = 1.0 if lane.shape == "step" or dur <= 0 else (t + dt - self.m.t_lane) / dur
        if lane.dimension == "distance" and lane.shape != "step":
            tau = self.m.s_lane / max(lane.amount, TOL)
        d = lane.target * LANE_WIDTH * _shape(lane.shape, tau)
        x0, y0, h0 = self.m.origin
        s = self.m.s_lane
        nx, ny = x0 + s * math.cos(h0) - d * math.sin(h0), y0 + s * math.sin(h0) + d * math.cos(h0)
        if tau >= 1.0:
            self.h = h0
        elif step > TOL:
            self.h = h0 + math.atan2(d - self.m.d_from, step)
        self.m.d_from = d
        self.x, self.y = nx, ny


@dataclass
class Played:
    """Every entity's pose at t = k * dt (k = 0 .. steps), and when each event started."""

    dt: float
    poses: dict[str, list[Pose]]
    started: dict[str, int] = field(default_factory=dict)  # event name -> step it started at
    held: dict[str, int] = field(default_factory=dict)  # event name -> step its condition held at
    # signal id (or 'entity.property') -> [(step, state)]
    signals: dict[str, list[tuple[int, str]]] = field(default_factory=dict)


def delay_of(ev: Event) -> float:
    """[s] from when an event's condition holds to when it starts (its conditions' longest delay)."""
    return max((c.delay for g in ev.groups for c in g), default=0.0)


def _measure(c: Condition, movers: dict[str, Mover], t: float, frame: tuple[float, float]) -> bool:
    if c.kind == "time":
        return _holds(t, c.rule, c.value)
    e = movers.get(c.entity)
    if e is None:
        raise ConfigError(f"a condition names {c.entity!r}, which is not an entity of the file")
    if c.kind in ("distance", "ttc"):
        assert c.point is not None
        d = math.hypot(c.point[0] - e.x, c.point[1] - e.y)
        value = d if c.kind == "distance" else (d / e.v if e.v > MIN_SPEED else math.inf)
        return _holds(value, c.rule, c.value)
    if c.kind == "speed":
        return _holds(e.v, c.rule, c.value)
    ref = movers.get(c.ref)
    if ref is None:
        raise ConfigError(f"a relative distance condition names {c.ref!r}, which is not an entity of the file")
    ahead = (e.x - ref.x) * frame[0] + (e.y - ref.y) * frame[1]
    return _holds(ahead, c.rule, c.value)


def fires(ev: Event, movers: dict[str, Mover], t: float, frame: tuple[float, float],
          spec: tuple | None, ego: str) -> bool:
    """Whether ``ev`` starts at ``t``: through its trigger ``spec`` when it has one (the same
    function the simulation runs), else through its conditions."""
    if spec is not None:
        e, a = movers[ego], movers[ev.actor]
        return trigger_fired(spec, t, e.x, e.y, e.v, a.x, a.y)
    return any(all(_measure(c, movers, t, frame) for c in g) for g in ev.groups) if ev.groups else True


def play(parsed: ParsedScenario, *, ego: str, dt: float, duration: float,
         specs: dict[str, tuple | None] | None = None, only: set[str] | None = None) -> Played:
    """Run the storyboard for ``duration`` [s] at steps of ``dt`` [s]. ``specs``: event name ->
    the trigger the simulation uses for it; ``only``: play just these events (None: all)."""
    specs = specs or {}
    movers = {n: Mover(*parsed.start[n], parsed.speed.get(n, 0.0)) for n in parsed.entities}
    x0, y0, h0 = parsed.start[ego]
    frame = (math.cos(h0), math.sin(h0))
    pending = [ev for ev in parsed.events if only is None or ev.name in only]
    out = Played(dt=dt, poses={n: [m.pose] for n, m in movers.items()})
    steps = int(round(duration / dt))
    for k in range(steps + 1):
        t = k * dt
        for ev in list(pending):
            if ev.name not in out.held and fires(ev, movers, t, frame, specs.get(ev.name), ego):
                out.held[ev.name] = k
            if ev.name in out.held and t >= out.held[ev.name] * dt + delay_of(ev) - TOL:
                pending.remove(ev)
                out.started[ev.name] = k
                for a in ev.actions:
                    movers[ev.actor].start(a, t)
                    if a.kind == "signal":
                        out.signals.setdefault(a.signal, []).append((k, a.state))
                    elif a.kind == "state":
                        out.signals.setdefault(f"{a.entity or ev.actor}.{a.key}", []).append((k, a.state))
        if k == steps:
            break
        for n, m in movers.items():
            m.advance(t, dt)
            out.poses[n].append(m.pose)
    return out


__all__ = ["Mover", "Played", "Pose", "delay_of", "fires", "play"]
