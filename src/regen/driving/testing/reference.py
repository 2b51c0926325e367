"""The reference driver: the project's careful human driver, used to decide whether a cause
*causes* the ego's behavior (:mod:`regen.driving.testing.causal`).

The scripted ego template performs its behavior whatever the world does, so it proves that a
scenario is feasible, never that the cause made the ego react. The reference driver reacts only
to what it sees, through the same harness and observations as any policy under test
(:func:`regen.driving.testing.loop.run_policy`). Its rules, each from a published model where one
exists:

- **Car following and stopping** (IDM, Treiber, Hennecke and Helbing 2000), the built-in
  :class:`~regen.driving.testing.policies.IDM` with its parameters: desired time headway
  T = 1.5 s, minimum gap s0 = 2 m, maximum acceleration a = 2 m/s^2, comfortable deceleration
  b = 3 m/s^2, exponent delta = 4. The nearest of these is its leader: an actor in its path; an
  actor whose motion brings it into the path within 3 s (a pedestrian, cyclist or car crossing),
  stopped where it will enter; a pedestrian standing or stepping towards the path within 1.5 m
  beside it (it waits until the pedestrian has stepped clear; one walking along the pavement
  beside the path at 0.5 m/s or more is passed); a red light, or a yellow one it can stop for at 3 m/s^2 (a stop
  line 2 m before the light); a dark light (``light_state`` off: out of order), treated as an
  all-way stop as most traffic codes require (a stop line 2 m before it, kept until it has stood
  there ``dark_wait`` = 2 s); an emergency vehicle with its siren on coming closer within 40 m
  (a stop line 12 m ahead of where it noticed it, kept while it comes closer: it stops and lets
  it pass); a vehicle standing in its lane (a police
  checkpoint, a broken-down car).
- **Moving off**: standing still, it waits while a leader within ``start_hold`` = 30 m stands
  (a red light, a queued car, a person in its path) instead of creeping up to it as IDM would.
- **Hazards ahead**: a static object (debris, a cone, a barrier, a box) or a vehicle with its
  hazard lights on, ahead within ``hazard_reach`` = 30 m and beside its lane within
  ``hazard_margin`` = 2.5 m (not in it: that is a leader), lowers its desired speed to
  ``hazard_speed_share`` = 0.6 of the cruise speed until it has passed (above its desired speed
  IDM's free term brakes at most at the comfortable deceleration b).
- **Lane changes** (MOBIL, Kesting, Treiber and Helbing 2007), where the road has another lane in
  its direction (:class:`Lanes`) and its own lane is blocked (the nearest thing ahead in it is a
  static object, a vehicle with its hazard lights on, or a moving vehicle slower than
  ``slow_share`` = 0.7 of its desired speed that has not slowed (by more than 0.5 m/s^2) in the
  last 3 s: it reads motion, not brake lights, which may be broken; never a person, whom it yields to, a standing emergency vehicle with its siren
  on, a checkpoint it stops at, nor a vehicle that stopped in traffic, which it waits behind): it changes to an adjacent lane when the incentive
  ``a~_ego - a_ego + p * ((a~_n - a_n) + (a~_o - a_o)) > delta_a_th`` holds and the new follower
  would brake no harder than ``b_safe``; politeness p = 0.3, threshold delta_a_th = 0.2 m/s^2,
  b_safe = 4 m/s^2, and a keep-lane bias of 0.3 m/s^2 against changing. Accelerations are the
  IDM's (a: now, a~: after the change; n: the new lane's follower, o: the old lane's). It moves
  across at ``lateral_speed`` = 1 m/s and commits to a change once started.

A policy sees no lanes, so :class:`ReferenceDriver` takes them from whoever builds it (the causal
check reads them off the scenario's road). Built without lanes, it never changes lane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from regen.driving.testing.policies import (
    IDM,
    MAX_ACCEL,
    MAX_BRAKE,
    Action,
    ActorState,
    EgoState,
    Observation,
    Obstacle,
    dark_lights_ahead,
    obstacles_in_path,
    path_frame,
    red_lights_ahead,
    route_curvature,
    sirens_closing,
)

HAZARD_ASSETS_CATEGORY = "static"  # what a hazard is by category (debris, cones, barriers, boxes)


@dataclass(frozen=True)
class Lanes:
    """The lanes in the ego's direction beside the one its route keeps, as lateral offsets [m]
    from the route (positive to the left); e.g. ``Lanes((3.5,))``: one lane to the left."""

    offsets: tuple[float, ...] = ()


def _shifted(ego: EgoState, route_offset: float, move: float = 0.0) -> EgoState:
    """The ego with its route shifted ``route_offset`` [m] to the left (a lane beside it), and
    itself moved ``move`` [m] to the left (as if it drove there)."""
    nx, ny = -math.sin(ego.heading), math.cos(ego.heading)
    far = next(((px, py) for px, py in ego.route_ahead if math.hypot(px - ego.x, py - ego.y) > 5.0), None)
    if far is not None:  # the route's own left normal (the heading wanders during a change)
        d = math.hypot(far[0] - ego.x, far[1] - ego.y)
        nx, ny = -(far[1] - ego.y) / d, (far[0] - ego.x) / d
    route = tuple((px + route_offset * nx, py + route_offset * ny) for px, py in ego.route_ahead)
    return replace(ego, x=ego.x + move * nx, y=ego.y + move * ny, route_ahead=route)


@dataclass
class ReferenceDriver:
    """IDM following with stops for lights, sirens and yielding, slowing for hazards, and MOBIL
    lane changes (module docstring: every rule and parameter with its unit)."""

    lanes: Lanes = field(default_factory=Lanes)
    idm: IDM = field(default_factory=IDM)
    hazard_reach: float = 30.0  # [m] ahead
    hazard_margin: float = 2.5  # [m] beside the ego's lane (its edge)
    hazard_speed_share: float = 0.6  # desired speed near a hazard, share of the cruise speed
    politeness: float = 0.3  # MOBIL p
    threshold: float = 0.2  # MOBIL delta_a_th [m/s^2]
    keep_lane_bias: float = 0.3  # [m/s^2] an incentive must beat this too
    b_safe: float = 4.0  # [m/s^2] the most a new follower may have to brake
    lateral_speed: float = 1.0  # [m/s] across lanes
    slow_share: float = 0.7  # a vehicle ahead slower than this share of its desired speed is slow
    braking_decel: float = 0.5  # [m/s^2] a vehicle slowing faster than this is braking ...
    braked_memory: float = 3.0  # [s] ... and counts as traffic, not as slow, this long after
    start_hold: float = 30.0  # [m] standing, it waits for what stands this near ahead to clear
    siren_stop_in: float = 12.0  # [m] ahead of where it notices a siren closing in, it stops
    dark_wait: float = 2.0  # [s] it stands at a dark light (out of order) before it goes on

    def __post_init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.offset = 0.0  # where it is now, from its route [m], left positive
        self.target = 0.0  # the lane it is in or moving to
        self._yield_at: dict[str, tuple[float, float]] = {}  # siren vehicle -> where it stops [m]
        self._speeds: dict[str, tuple[float, float]] = {}  # vehicle -> (t [s], speed [m/s]) last seen
        self._braked_at: dict[str, float] = {}  # vehicle -> when it last slowed [s]
        self._dark_since: dict[str, float] = {}  # dark light -> since when it stands at it [s]
        self._dark_done: set[str] = set()  # dark lights it has stopped at and may pass
        #: per step, (t [s], what it reacted to: its leader, a hazard it slowed for, or None)
        self.reacting_to: list[tuple[float, str | None]] = []

    # --- longitudinal ------------------------------------------------------------------------

    def _leaders(self, obs: Observation) -> list[Obstacle]:
        m = self.idm
        return (obstacles_in_path(obs, horizon=m.yield_horizon, pedestrian_margin=m.pedestrian_margin)
                + red_lights_ahead(obs) + self._give_way(obs) + self._dark_lights(obs))

    def _dark_lights(self, obs: Observation) -> list[Obstacle]:
        """Stop lines at dark lights ahead (an all-way stop) it has not yet stood at for
        ``dark_wait``; standing within 3 m of one starts that wait."""
        out = []
        for stop in dark_lights_ahead(obs):
            if stop.name in self._dark_done:
                continue
            if obs.ego.speed < 0.3 and stop.gap < 3.0:
                since = self._dark_since.setdefault(stop.name, obs.t)
                if obs.t - since >= self.dark_wait:
                    self._dark_done.add(stop.name)
                    continue
            out.append(stop)
        return out

    def _give_way(self, obs: Observation) -> list[Obstacle]:
        """Stop lines for emergency vehicles with their siren on coming closer: fixed where it
        first noticed each (``siren_stop_in`` ahead), kept until that one no longer closes in."""
        ego = obs.ego
        closing = {o.name for o in sirens_closing(obs, stop_in=self.siren_stop_in)}
        for name in list(self._yield_at):
            if name not in closing:
                del self._yield_at[name]
        out = []
        for name in closing:
            if name not in self._yield_at:
                d = self.siren_stop_in + ego.length / 2
                self._yield_at[name] = (ego.x + d * math.cos(ego.heading), ego.y + d * math.sin(ego.heading))
            s, _, _, _ = path_frame(ego, *self._yield_at[name])
            out.append(Obstacle(max(s - ego.length / 2, 0.0), 0.0, name))
        return out

    def _hazard(self, obs: Observation) -> str | None:
        """The hazard beside its lane ahead that it slows for, if any."""
        ego = obs.ego
        for a in obs.actors:
            if not (a.category == HAZARD_ASSETS_CATEGORY or a.hazard_lights == "on"):
                continue
            s, lat, _, _ = path_frame(ego, a.x, a.y)
            half = a.width / 2 if a.category == "vehicle" else max(a.width, a.length) / 2  # beside it
            edge = abs(lat) - ego.width / 2 - half
            if 0.0 < s <= self.hazard_reach + ego.length and 0.0 < edge <= self.hazard_margin:
                return a.name
        return None

    def _accel(self, obs: Observation, v0: float, *, clip: bool = True) -> float:
        """IDM's acceleration [m/s^2]; above its desired speed (slowing for a hazard) the free
        term brakes at most ``comfort_decel``. ``clip``: within what the car can do."""
        m, v = self.idm, obs.ego.speed
        acc = max(m.max_accel * (1.0 - (v / max(v0, 0.1)) ** m.delta), -m.comfort_decel)
        leaders = self._leaders(obs)
        if leaders:
            lead = min(leaders, key=lambda o: o.gap)
            acc -= m.max_accel * (self._s_star(v, v - max(lead.speed, 0.0)) / max(lead.gap, 0.1)) ** 2
        return max(-MAX_BRAKE, min(MAX_ACCEL, acc)) if clip else acc

    def _s_star(self, v: float, dv: float) -> float:
        m = self.idm
        return m.min_gap + max(0.0, v * m.time_headway + v * dv / (2 * math.sqrt(m.max_accel * m.comfort_decel)))

    def _follower_accel(self, follower: ActorState, gap: float, lead_speed: float | None, v0: float) -> float:
        """IDM acceleration [m/s^2] of a vehicle ``gap`` [m] behind a leader (None: free road)."""
        m, v = self.idm, follower.speed
        acc = m.max_accel * (1.0 - (v / max(v0, 0.1)) ** m.delta)
        if lead_speed is not None:
            acc -= m.max_accel * (self._s_star(v, v - lead_speed) / max(gap, 0.1)) ** 2
        return acc

    def _binding(self, obs: Observation, me: EgoState, leaders: list[Obstacle]) -> bool:
        """Whether the nearest leader makes it brake or hold back (IDM's interaction term is
        larger than a tenth of its free acceleration's range)."""
        m, v = self.idm, me.speed
        lead = min(leaders, key=lambda o: o.gap)
        inter = m.max_accel * (self._s_star(v, v - max(lead.speed, 0.0)) / max(lead.gap, 0.1)) ** 2
        return inter > 0.1 * m.max_accel

    def _held(self, leaders: list[Obstacle]) -> bool:
        """Standing, whether something standing within ``start_hold`` ahead holds it there (a red
        light, a vehicle or a person in or entering its path): it moves off once that clears,
        rather than creeping up to it."""
        return any(o.speed < 0.5 and o.gap < self.start_hold for o in leaders)

    # --- lateral (MOBIL) -----------------------------------------------------------------------

    def _follower(self, obs: Observation, ego: EgoState) -> tuple[ActorState, float] | None:
        """The nearest vehicle behind ``ego`` in its lane, with its bumper gap [m]."""
        best = None
        for a in obs.actors:
            if a.category != "vehicle":
                continue
            s, lat, _, _ = path_frame(ego, a.x, a.y)
            gap = -s - ego.length / 2 - a.length / 2
            if s < 0 and abs(lat) <= (ego.width + a.width) / 2 + 0.3 and (best is None or gap < best[1]):
                best = (a, gap)
        return best

    def _view(self, ego: EgoState, lane: float) -> EgoState:
        """The ego as if in the lane ``lane`` [m] left of its route (it is at ``self.offset``)."""
        return _shifted(ego, lane, lane - self.offset)

    def _incentive(self, obs: Observation, offset: float, v0: float) -> float | None:
        """MOBIL's incentive [m/s^2] to move to ``offset``, or None when unsafe."""
        here = self._view(obs.ego, self.target)
        there = self._view(obs.ego, offset)
        a_now = self._accel(replace(obs, ego=here), v0, clip=False)
        a_new = self._accel(replace(obs, ego=there), v0, clip=False)
        gain = a_new - a_now
        v = obs.ego.speed
        for ego_pos, joins in ((there, True), (here, False)):
            found = self._follower(obs, ego_pos)
            if found is None:
                continue
            f, gap = found
            f0 = max(f.speed, v0)
            leaders = [o for o in obstacles_in_path(replace(obs, ego=ego_pos)) if o.name != f.name]
            ahead = min(leaders, key=lambda o: o.gap) if leaders else None
            # the follower's leader: the ego when it joins (or before it leaves), else the ego's leader
            if joins:
                before = self._follower_accel(f, gap + ego_pos.length + (ahead.gap if ahead else 1e3),
                                              ahead.speed if ahead else None, f0)
                after = self._follower_accel(f, gap, v, f0)
                if after < -self.b_safe:
                    return None
            else:
                before = self._follower_accel(f, gap, v, f0)
                after = self._follower_accel(f, gap + ego_pos.length + (ahead.gap if ahead else 1e3),
                                             ahead.speed if ahead else None, f0)
            gain += self.politeness * (after - before)
        return gain

    def _blocked(self, obs: Observation, v0: float) -> bool:
        """Whether its lane is blocked: the nearest thing in it ahead (within 60 m) is a static
        object, a vehicle with its hazard lights on, or a moving vehicle slower than
        ``slow_share`` of its desired speed that has not slowed lately, and neither a person (it yields
        to people) nor an emergency vehicle with its siren on (a checkpoint: it stops)."""
        ahead = obstacles_in_path(replace(obs, ego=self._view(obs.ego, self.target)))
        if not ahead:
            return False
        lead = ahead[0]
        actor = next((a for a in obs.actors if a.name == lead.name), None)
        if actor is None or actor.category == "pedestrian" or actor.siren == "on":
            return False
        if actor.category == "static" or actor.hazard_lights == "on":
            return True
        # a slow vehicle (a cyclist, a bus, one coming the wrong way); one that slowed lately or
        # stands in its lane is traffic that stops for a reason: it waits behind it. It reads the
        # motion, not the brake lights (which may be broken)
        braked = self._braked_at.get(actor.name)
        recently = braked is not None and obs.t - braked <= self.braked_memory
        return lead.speed < self.slow_share * v0 and actor.speed > 0.5 and not recently

    def _watch(self, obs: Observation) -> None:
        """Remember when each vehicle last slowed by more than ``braking_decel``."""
        for a in obs.actors:
            if a.category != "vehicle":
                continue
            before = self._speeds.get(a.name)
            if before is not None and obs.t > before[0] and (before[1] - a.speed) / (obs.t - before[0]) > self.braking_decel:
                self._braked_at[a.name] = obs.t
            self._speeds[a.name] = (obs.t, a.speed)

    def _choose_lane(self, obs: Observation, v0: float) -> None:
        if abs(self.offset - self.target) > 1e-6 or not self.lanes.offsets or not self._blocked(obs, v0):
            return  # moving across (committed), no other lane, or nothing to go around
        options = [0.0, *self.lanes.offsets]
        here = self.target
        best, best_gain = here, self.threshold + self.keep_lane_bias
        for off in options:
            if off == here or min(abs(off - o) for o in options if o != off) < abs(off - here) - 1e-6:
                continue  # its own lane, or not adjacent
            gain = self._incentive(obs, off, v0)
            if gain is not None and gain > best_gain:
                best, best_gain = off, gain
        self.target = best

    # --- the policy ------------------------------------------------------------------------------

    def __call__(self, obs: Observation) -> Action:
        ego = obs.ego
        v0 = max(ego.cruise_speed, 0.1)
        if self._hazard(replace(obs, ego=self._view(ego, self.offset))) is not None:
            v0 = max(ego.cruise_speed * self.hazard_speed_share, 0.1)
        self._watch(obs)
        before = self.target
        self._choose_lane(obs, v0)
        step = self.lateral_speed * obs.dt
        self.offset += max(-step, min(step, self.target - self.offset))
        me = self._view(ego, self.offset)  # where it is, its route shifted to its lane
        leaders = self._leaders(replace(obs, ego=me))
        near = min(leaders, key=lambda o: o.gap).name if leaders else None
        hazard = self._hazard(replace(obs, ego=me))
        why = near if near is not None and self._binding(obs, me, leaders) else hazard
        if self.target != before:  # a lane change starts: for what blocks its lane
            ahead = obstacles_in_path(replace(obs, ego=self._view(ego, before)))
            why = ahead[0].name if ahead else why
        self.reacting_to.append((obs.t, why))
        if ego.speed < 0.3 and self._held(leaders):
            return Action(-MAX_BRAKE, route_curvature(me))
        # during a change it watches both lanes: the nearer leader of either counts
        acc = self._accel(replace(obs, ego=me), v0)
        if abs(self.offset - self.target) > 1e-6:
            acc = min(acc, self._accel(replace(obs, ego=self._view(ego, self.target)), v0))
        return Action(acc, route_curvature(me))


__all__ = ["Lanes", "ReferenceDriver"]
