"""The driving domain's reference world: a grounded scenario driven by the reference driver
(:class:`~regen.driving.testing.reference.ReferenceDriver`) instead of the scripted ego, with
chosen entities left out (the but-for check of :mod:`regen.verify.causal`).

Every world keeps the map, the other entities and their solved parameters; an entity left out
takes its FSM states with it (and the predicates of others that name it). The reference driver
drives the template's route in the lane it starts in (a route that changes lane is straightened:
whether to change lane is the driver's own decision), through the policy harness
(:func:`regen.driving.testing.loop.run_policy`).

What the reference must show, per ego template (:attr:`EgoTemplate.reaction_class`), read off
its recorded speed and lateral offset:

- ``stops``: it drove at 3 m/s or more, then stood (under 0.5 m/s) or braked to half its top
  speed or less: a careful driver who anticipates a child running across brakes early and need
  not come to a standstill before the child is clear;
- ``slows down``: its speed fell by at least 2 m/s and a fifth of its cruise speed;
- ``drives off``: it stood still for at least 1 s (after creeping up to what holds it, as IDM
  does), then reached 2 m/s;
- ``changes lane``: it moves 0.6 lane widths or more to the side of the lane it started in (at
  any time: one that overtakes and comes back changed lane).

The reaction's onset is when it started braking (or moving, or moving across). With the cause
present, the behavior counts when the driver reacted to an entity of the cause (what it braked
for, waited for, or changed lane around), or else when its onset is no earlier than
``ANTICIPATION`` = 3 s before the cause first shows (the FSM's cause states, on this run): the
reference driver yields to an actor up to 3 s before it enters its path, never earlier.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from regen.core.scenario import FSM, AbstractState, Scenario, Stage
from regen.core.trace import Trace
from regen.core.verdict import ReferenceRun
from regen.driving.testing import loop
from regen.driving.testing.reference import Lanes, ReferenceDriver
from regen.verify.causal import NotCheckable

ANTICIPATION = 3.0  # [s] the earliest a reaction may start before the cause shows
MOVING = 3.0  # [m/s] driving, before a stop
STILL = 0.5  # [m/s] standing
NEAR_STOP_SHARE = 0.5  # braking to this share of its top speed or less is a stop's reaction
SLOWED_BY = 2.0  # [m/s] and
SLOWED_SHARE = 0.2  # of the cruise speed: the least drop that is slowing down
WAITED = 1.0  # [s] standing at the start before driving off
DRIVEN_OFF = 2.0  # [m/s]
LANE_SHARE = 0.6  # of a lane width to the side: a lane change
BY = "reference driver (IDM following, MOBIL lane changes)"


def without(scenario: Scenario, removed: frozenset[str]) -> Scenario:
    """``scenario`` with the entities ``removed`` left out: their states, the predicates of
    others that name them, stages left empty, and their solved parameters."""
    if not removed:
        return scenario
    states: list[AbstractState] = []
    for st in scenario.fsm.states:
        if st.actor in removed:
            continue
        calls = [c for c in st.all_of if not set(c.args) & removed]
        if calls:
            states.append(st.model_copy(update={"all_of": calls}))
    known = {(s.actor, s.name) for s in states}
    stages = []
    for stage in scenario.fsm.stages:
        conds = [c for c in stage.conditions if (c.actor, c.state) in known]
        if conds:
            stages.append(Stage(conditions=conds))
    return scenario.model_copy(update={
        "entities": [e for e in scenario.entities if e.name not in removed],
        "fsm": FSM(states=states, stages=stages),
        "parameters": {k: v for k, v in scenario.parameters.items() if k not in removed}})


def _lateral(trace: Trace, frame, route: tuple[tuple[float, float], ...] = ()) -> np.ndarray:
    """The ego's signed offset [m] to the left of its ``route`` at every step: from the nearest
    segment of the polyline (the first extended backwards, the last forwards), so that following
    the route through a turn is no move across; without a route, from the road's ``frame``."""
    ego = trace.actors["ego"]
    x, y = np.asarray(ego.x, dtype=float), np.asarray(ego.y, dtype=float)
    pts = np.asarray(route, dtype=float).reshape(-1, 2)
    d = np.diff(pts, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > 1e-6
    if not keep.any():
        return (x - frame.ox) * -frame.uy + (y - frame.oy) * frame.ux
    p0, u, length = pts[:-1][keep], d[keep] / length[keep, None], length[keep]
    rx, ry = x[:, None] - p0[None, :, 0], y[:, None] - p0[None, :, 1]
    lon = rx * u[None, :, 0] + ry * u[None, :, 1]
    lat = -rx * u[None, :, 1] + ry * u[None, :, 0]
    lo = np.zeros(len(length))
    lo[0] = -np.inf
    hi = length.copy()
    hi[-1] = np.inf
    err = np.hypot(lon - np.clip(lon, lo, hi), lat)
    return lat[np.arange(len(x)), np.argmin(err, axis=1)]


def _onset_before(speed: np.ndarray, k: int, dt: float, *, rising: bool = False) -> int:
    """The step the speed change that reaches step ``k`` began (it kept falling, or rising, since)."""
    i = k
    while i > 0:
        d = (speed[i] - speed[i - 1]) / dt
        if (d > 0.3) if rising else (d < -0.3):
            i -= 1
        else:
            break
    return i


def shows(trace: Trace, reaction: str, *, frame, lane_width: float, cruise: float,
          route: tuple[tuple[float, float], ...] = ()) -> tuple[bool, int | None, str]:
    """(whether the reference ego shows ``reaction``, the step its reaction started, what it did
    in words: where it does not, and changes lane instead, that too). A lane change is a move
    across its ``route`` (the road's ``frame`` without one)."""
    kw = {"frame": frame, "lane_width": lane_width, "cruise": cruise, "route": route}
    shown, onset, words = _shows(trace, reaction, **kw)
    if not shown and reaction != "changes lane":
        moved, _, how = _shows(trace, "changes lane", **kw)
        if moved:  # a slow truck it overtakes rather than slowing behind it
            words += f"; it {how.split(' (')[0]} instead"
    return shown, onset, words


def _shows(trace: Trace, reaction: str, *, frame, lane_width: float, cruise: float,
           route: tuple[tuple[float, float], ...] = ()) -> tuple[bool, int | None, str]:
    v = np.asarray(trace.actors["ego"].speed, dtype=float)
    t = trace.times
    if reaction == "stops":
        fast = np.flatnonzero(v >= MOVING)
        if fast.size:
            k0 = int(fast[0])
            top = np.maximum.accumulate(v[k0:])
            low = np.flatnonzero((v[k0:] < STILL) | (v[k0:] <= NEAR_STOP_SHARE * top))
            if low.size:
                k = k0 + int(low[0])
                on = _onset_before(v, k, trace.dt)
                still = np.flatnonzero(v[k:] < STILL)
                if still.size:
                    how = f"stops at t = {t[k + int(still[0])]:.1f} s"
                else:
                    how = f"brakes from {float(top[k - k0]):.1f} to {float(v[k:].min()):.1f} m/s by t = {t[k]:.1f} s"
                return True, on, f"{how} (braking from t = {t[on]:.1f} s)"
            return False, None, (f"never stops nor brakes to half its speed (slowest {float(v[k0:].min()):.1f} "
                                 f"m/s after driving {float(top.max()):.1f} m/s)")
        return False, None, "never drives 3 m/s, so never stops from driving"
    if reaction == "slows down":
        top = max(float(v[0]), cruise)
        need = top - max(SLOWED_BY, SLOWED_SHARE * top)
        low = np.flatnonzero(v <= need)
        if low.size:
            k = int(low[0])
            on = _onset_before(v, k, trace.dt)
            return True, on, f"slows to {v[k]:.1f} m/s by t = {t[k]:.1f} s (from t = {t[on]:.1f} s)"
        return False, None, f"keeps its speed (slowest {float(v.min()):.1f} m/s, cruise {top:.1f} m/s)"
    if reaction == "drives off":
        still = v < STILL
        k, n = 0, len(v)
        while k < n:  # the first standstill of WAITED or longer, then driving off
            if not still[k]:
                k += 1
                continue
            j = k
            while j < n and still[j]:
                j += 1
            if t[j - 1] - t[k] >= WAITED and j < n:
                off = np.flatnonzero(v[j:] >= DRIVEN_OFF)
                if off.size:
                    return True, j, f"waits {t[j - 1] - t[k]:.1f} s, then drives off at t = {t[j]:.1f} s"
            k = j
        return False, None, "never waits and then drives off (it drives off at once: nothing holds it)" \
            if not still[0] or (still.size and t[int(np.argmin(still))] - t[0] < WAITED) else \
            "never drives off after waiting"
    if reaction == "changes lane":
        d = _lateral(trace, frame, route)
        off = np.abs(d - d[0])
        across = np.flatnonzero(off >= LANE_SHARE * lane_width)
        if across.size:
            k = int(across[0])
            on = int(np.flatnonzero(off >= 0.3)[0])
            return True, on, f"changes lane at t = {t[k]:.1f} s (moving across from t = {t[on]:.1f} s)"
        return False, None, f"keeps its lane (at most {float(off.max()):.1f} m to the side)"
    raise NotCheckable(f"no reference behavior class {reaction!r}")


def cause_time(scenario: Scenario, trace: Trace, cause: frozenset[str]) -> float | None:
    """[s] when a cause state of an entity of ``cause`` first held on ``trace``."""
    from regen.verify.monitor import evaluate_state

    first = None
    for st in scenario.fsm.states:
        if not st.cause or st.actor not in cause:
            continue
        hits = np.flatnonzero(evaluate_state(st, trace, scenario.domain))
        if hits.size and (first is None or trace.times[int(hits[0])] < first):
            first = float(trace.times[int(hits[0])])
    return first


@dataclass
class DrivingReferenceWorld:
    """The scenario's world with the reference driver (:class:`regen.verify.causal.ReferenceWorld`)."""

    scenario: Scenario
    cause: frozenset[str]
    by: str = BY
    behavior: str = ""
    _runs: dict[frozenset[str], ReferenceRun] = field(default_factory=dict, init=False, repr=False)
    _whole: loop.Prepared | None = field(default=None, init=False, repr=False)  # the run with nothing removed

    def __post_init__(self) -> None:
        from regen.driving.grounding.rules import template_of

        t = template_of(self.scenario)
        self.template = t
        self.behavior = t.reaction_class
        self.frame = t.frame
        self.lanes, self.route = Lanes(), tuple(t.route)
        if t.map == "straight" and not t.replay:
            fr, d0 = t.frame, t.frame.lane_d(t.ego_lane)
            # its own lane all along: whether to change lane is its decision
            self.route = tuple(fr.point((x - fr.ox) * fr.ux + (y - fr.oy) * fr.uy, d0) for x, y in t.route)
            self.lanes = Lanes(tuple(fr.lane_d(k) - d0 for k in range(fr.lanes_same_direction) if k != t.ego_lane))
        self.cruise = max([t.speed0] + [s for _, s, _ in t.schedule])

    def run(self, removed: frozenset[str]) -> ReferenceRun:
        """The reference driver in the world without ``removed`` (a run asked for twice is
        simulated once). The worlds with fewer entities reuse the compiled program of the
        whole world, their objects left out (:func:`regen.driving.testing.loop.prepare`)."""
        if removed not in self._runs:
            self._runs[removed] = self._run(removed)
        return self._runs[removed].model_copy(deep=True)

    def _run(self, removed: frozenset[str]) -> ReferenceRun:
        world = without(self.scenario, removed)
        prep = loop.prepare(world, within=self._whole)
        if not removed:
            self._whole = prep
        prep = dataclasses.replace(prep, template=dataclasses.replace(prep.template, route=self.route))
        driver = ReferenceDriver(lanes=self.lanes)
        ep = loop.run_policy(prep, driver, step_timeout=None)
        if ep.trace is None:
            return ReferenceRun(removed=sorted(removed), shown=False, happened=False,
                                summary=f"the run failed: {ep.failure}")
        shown, onset, words = shows(ep.trace, self.behavior, frame=self.frame, route=self.route,
                                    lane_width=self.frame.lane_width, cruise=self.cruise)
        at = cause_time(world, ep.trace, self.cause - removed) if self.cause - removed else None
        t_on = float(ep.trace.times[onset]) if onset is not None else None
        happened = shown
        why = _reacting_to(driver, t_on) if shown and t_on is not None else None
        if why:
            words += f", for {why}"
        if shown and self.cause - removed and why not in self.cause:  # not its own word: the FSM's timing
            if at is None:
                shown, words = False, f"{words}, but the cause never showed"
            elif t_on is not None and t_on < at - ANTICIPATION:
                shown, words = False, (f"{words}, {at - t_on:.1f} s before the cause showed "
                                       f"(t = {at:.1f} s): not a reaction to it")
        return ReferenceRun(removed=sorted(removed), shown=shown, happened=happened, reacted_to=why,
                            onset=t_on, cause_at=at, summary=words)


def _reacting_to(driver: ReferenceDriver, t: float) -> str | None:
    """What the driver reacted to in the second after ``t`` (its most frequent reason)."""
    names = [n for tt, n in driver.reacting_to if t - 0.05 <= tt <= t + 1.0 and n]
    if not names:
        names = [n for tt, n in driver.reacting_to if tt >= t and n][:1]
    return max(set(names), key=names.count) if names else None


def reference_world(scenario: Scenario, cause: list[str]) -> DrivingReferenceWorld:
    """The reference world of a driving scenario (its ego template says what to show)."""
    return DrivingReferenceWorld(scenario, frozenset(cause))


__all__ = ["ANTICIPATION", "BY", "DrivingReferenceWorld", "cause_time", "reference_world", "shows", "without"]
