"""CP-SAT: choose start offsets, speeds and trigger times so the causes happen around the ego.

Units inside the model are integers: decimetres [dm], decimetres per second [dm/s] and
deciseconds [ds]. Every constraint is added behind its own enforcement literal named
``"actor: what it requires"``; when the model is infeasible, the solver's sufficient
assumptions name the constraints in conflict.

The ego's motion is known from its template: before its event it drives at a constant speed,
so its position along the frame at time t [s] is ``s_event - v_event * (t_event - t)``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from regen.core.scenario import SolverReport
from regen.driving.ego import EGO_SIZE, EgoTemplate
from regen.driving.maps import JUNCTION_RADIUS
from regen.driving.primitives import (
    LANE_CHANGE_LENGTH,
    PEDESTRIAN_ASSETS,
    REACTION_TIME,
    VEHICLE_SPEEDS,
    WALK_SPEEDS,
    roadside_d,
)
from regen.errors import DependencyNotInstalled

DM = 10  # decimetres per metre
STATE_ONLY = {"traffic_light", "gnss", "camera"}


@dataclass
class ActorSpec:
    """What the solver needs about one non-ego actor."""

    name: str
    asset: str
    primitive: str
    location: str
    speed_class: str
    size: tuple[float, float, float]
    properties: dict[str, str] = field(default_factory=dict)


@dataclass
class Solution:
    report: SolverReport
    params: dict[str, dict[str, float]] = field(default_factory=dict)  # actor -> s, v, t, ...


def _cp():
    try:
        from ortools.sat.python import cp_model
    except ModuleNotFoundError as exc:  # ortools is a core dependency; be explicit anyway
        raise DependencyNotInstalled("ortools", "driving", "solving scenario parameters") from exc
    return cp_model


class _Model:
    def __init__(self, ego: EgoTemplate):
        self.cp = _cp()
        self.m = self.cp.CpModel()
        self.ego = ego
        self.lits: dict[str, object] = {}
        self.vars: dict[str, dict[str, object]] = {}

    def require(self, name: str, expr) -> None:
        lit = self.m.NewBoolVar(name)
        self.m.Add(expr).OnlyEnforceIf(lit)
        key = name
        i = 2
        while key in self.lits:
            key = f"{name} ({i})"
            i += 1
        self.lits[key] = lit

    def int(self, actor: str, key: str, lo: float, hi: float, scale: int = DM):
        lo_i, hi_i = int(round(lo * scale)), int(round(hi * scale))
        if hi_i < lo_i:
            lo_i, hi_i = hi_i, lo_i
        var = self.m.NewIntVar(lo_i, hi_i, f"{actor}.{key}")
        self.vars.setdefault(actor, {})[key] = var
        return var

    def product(self, actor: str, key: str, a, b, bound: int):
        var = self.m.NewIntVar(-bound, bound, f"{actor}.{key}")
        self.m.AddMultiplicationEquality(var, [a, b])
        self.vars.setdefault(actor, {})[key] = var
        return var

    def ego_s(self, t: float) -> float:
        """Ego centre along the frame [m] at time t <= t_event [s]."""
        e = self.ego
        return e.s_event - e.speed_event * (e.t_event - t)


def _speed_range(spec: ActorSpec) -> tuple[float, float]:
    table = WALK_SPEEDS if spec.asset in PEDESTRIAN_ASSETS else VEHICLE_SPEEDS
    return table.get(spec.speed_class, table["moderate"])


def _add_actor(M: _Model, a: ActorSpec) -> None:  # noqa: C901 - one table of cases, kept together
    e = M.ego
    fr = e.frame
    n = a.name
    L, W = a.size[0], a.size[1]
    half = (L + EGO_SIZE[0]) / 2  # centre-to-centre length of two bumpers touching [m]
    te = e.t_event
    T = e.duration
    vlo, vhi = _speed_range(a)
    stops = e.stops
    if a.asset in STATE_ONLY:
        # lights and sensors only switch state: at t, shortly before the ego's event
        t = M.int(n, "t", 0.0, T)
        M.require(f"{n}: switches state 0.2 to 2.5 s before the ego's event (t={te:.1f} s)",
                  t >= int((te - 2.5) * DM))
        M.require(f"{n}: switches state no later than 0.2 s before the ego's event",
                  t <= int((te - 0.2) * DM))
        if a.asset == "traffic_light" and a.properties.get("light_state") == "turns_red":
            M.require(f"{n}: turns red after at least 2 s of yellow, so after t=2 s", t >= 2 * DM)
        return
    s = M.int(n, "s", -400.0, 400.0)
    v = M.int(n, "v", vlo, vhi)
    ego_end = e.s_end
    if a.primitive == "stationary":
        M.m.Add(v == int(vlo * DM))  # unused for stationary actors; pin it
        if a.properties.get("door") == "opens":
            t = M.int(n, "t", 0.0, T)
            M.require(f"{n}: opens its door 0.3 to 2.5 s before the ego's event",
                      t >= int((te - 2.5) * DM))
            M.require(f"{n}: opens its door at least 0.3 s before the ego's event",
                      t <= int((te - 0.3) * DM))
        if a.location in ("ahead_same_lane", "crosswalk_ahead"):
            lo = ego_end + half + 1.0
            hi = ego_end + half + (12.0 if stops else 30.0)
            M.require(f"{n}: stands in the ego's lane ahead of where the ego ends (s >= {lo:.1f} m)",
                      s >= int(lo * DM))
            M.require(f"{n}: stands close enough ahead to matter (s <= {hi:.1f} m)", s <= int(hi * DM))
        elif a.location in ("ahead_adjacent_lane", "roadside_ahead", "roadside_opposite_ahead"):
            ref = ego_end if stops else e.s_event
            M.require(f"{n}: stands ahead of the ego's event position", s >= int((ref + half - 4.0) * DM))
            M.require(f"{n}: stands within 30 m of it", s <= int((ref + 30.0) * DM))
        elif a.location == "behind_same_lane":
            M.require(f"{n}: stands behind the ego's start", s <= int((M.ego_s(0.0) - half - 3.0) * DM))
            M.require(f"{n}: stands within 40 m behind the ego's start",
                      s >= int((M.ego_s(0.0) - 40.0) * DM))
        return
    if a.primitive == "cross_the_road":
        t = M.int(n, "t", 0.0, T)
        side_d = fr.sidewalk_d("left" if a.location == "roadside_opposite_ahead" else "right")
        ego_d = fr.lane_d(e.ego_lane)
        reach = abs(side_d - ego_d) - fr.lane_width / 2  # walk [m] to the ego lane's near edge
        clear = abs(side_d - ego_d) + fr.lane_width / 2 + W / 2  # to its far edge [m]
        # time [ds] to walk `dist` [m] at v [dm/s] is dist*100/v: keep t + dist/v in a window via
        # (window - t) * v compared with dist * 100
        def walk_window(early: float, late: float, dist: float, early_text: str, late_text: str) -> None:
            """Cover ``dist`` [m] no later than ``early`` s and no sooner than ``late`` s before te."""
            for tag, offset, text, at_least in (("lo", early, early_text, True), ("hi", late, late_text, False)):
                slack = M.m.NewIntVar(-10000, 10000, f"{n}.slack_{tag}")
                M.m.Add(slack == int((te - offset) * DM) - t)
                prod = M.product(n, f"walk_{tag}", slack, v, 10 ** 7)
                M.require(f"{n}: {text}", prod >= int(dist * 100) if at_least else prod <= int(dist * 100))

        if e.speed_event == 0.0 and not stops:  # the ego waits: pedestrians clear its lane first
            lo_s, hi_s = e.s_event + EGO_SIZE[0] / 2 + 1.5, e.s_event + EGO_SIZE[0] / 2 + 8.0
            walk_window(0.3, 2.5, clear, "has crossed the ego's lane by 0.3 s before the ego starts",
                        "is still crossing 2.5 s before the ego starts")
        else:
            if stops:
                lo_s, hi_s = ego_end + EGO_SIZE[0] / 2 + 1.5, ego_end + EGO_SIZE[0] / 2 + 12.0
            else:
                lo_s, hi_s = e.s_event + 15.0, e.s_event + 35.0
            walk_window(0.2, 1.8, reach, "reaches the ego's lane by 0.2 s before the ego's event",
                        "reaches the ego's lane no earlier than 1.8 s before the ego's event")
        M.require(f"{n}: crosses ahead of where the ego ends (s >= {lo_s:.1f} m)", s >= int(lo_s * DM))
        M.require(f"{n}: crosses close enough to matter (s <= {hi_s:.1f} m)", s <= int(hi_s * DM))
        return
    if a.primitive == "walk_along":
        M.require(f"{n}: walks near the ego's event position", s >= int((e.s_event - 5.0) * DM))
        M.require(f"{n}: starts within 35 m ahead of it", s <= int((e.s_event + 35.0) * DM))
        return
    if a.location in ("junction_cross_street", "junction_oncoming"):
        d0 = M.int(n, "d0", 2.0, 140.0)
        # time to reach the junction edge: d0 / v; window [te - lo, te + hi] via products
        lo, hi = (1.0, 0.5) if a.primitive == "turn_left" else (0.6, 1.0)
        if a.primitive == "turn_right":
            lo, hi = 2.0, -0.2
        tl = int((te - lo) * DM)
        th = int((te + hi) * DM)
        M.require(f"{n}: enters the junction no earlier than {lo:.1f} s before the ego's event",
                  d0 * 10 >= v * tl)
        M.require(f"{n}: enters the junction no later than {hi:+.1f} s after the ego's event",
                  d0 * 10 <= v * th)
        return
    # vehicles in lanes
    same_d, adj_d = fr.lane_d(e.ego_lane), None
    if fr.lanes_same_direction > 1:
        adj_d = fr.lane_d(1 - e.ego_lane) if e.ego_lane in (0, 1) else None
    del same_d, adj_d
    s_te = M.m.NewIntVar(-100000, 100000, f"{n}.s_te")  # [dm] where it is at te if it keeps v
    te_ds = int(round(te * DM))
    M.m.Add(10 * s_te - 10 * s - v * te_ds >= 0)
    M.m.Add(10 * s_te - 10 * s - v * te_ds <= 9)
    loc = a.location
    if a.primitive == "drive_forward" and loc == "ahead_same_lane":
        if stops:
            t = M.int(n, "t", 0.0, T)
            M.require(f"{n}: brakes 0.3 to 1.5 s before the ego (t={te:.1f} s)", t >= int((te - 1.5) * DM))
            M.require(f"{n}: brakes at least 0.3 s before the ego", t <= int((te - 0.3) * DM))
            vt = M.product(n, "vt", v, t, 10 ** 7)
            sq = M.product(n, "v2", v, v, 10 ** 6)
            stop = M.m.NewIntVar(-100000, 100000, f"{n}.stop")  # [dm] where it comes to rest
            M.m.Add(1360 * stop >= 1360 * s + 136 * vt + 10 * sq + 140 * v - 1360)
            M.m.Add(1360 * stop <= 1360 * s + 136 * vt + 10 * sq + 140 * v + 1360)
            M.require(f"{n}: stops ahead of where the ego stops, with a gap of 1.5 to 10 m",
                      stop >= int((ego_end + half + 1.5) * DM))
            M.require(f"{n}: stops at most 10 m ahead of the ego's stop", stop <= int((ego_end + half + 10.0) * DM))
            M.require(f"{n}: drives at least as fast as the ego (v >= {e.speed_event:.0f} m/s)",
                      v >= int(e.speed_event * DM))
            M.require(f"{n}: starts ahead of the ego", s >= int((M.ego_s(0.0) + half + 3.0) * DM))
        elif e.speed_event == 0.0:  # the ego waits behind it, then both go
            t = M.int(n, "t", 0.0, T)
            M.require(f"{n}: departs 0.5 to 2 s before the ego", t >= int((te - 2.0) * DM))
            M.require(f"{n}: departs at least 0.5 s before the ego", t <= int((te - 0.5) * DM))
            M.require(f"{n}: waits 3 to 8 m ahead of the ego", s >= int((e.s_event + half + 3.0) * DM))
            M.require(f"{n}: waits at most 8 m ahead of the ego", s <= int((e.s_event + half + 8.0) * DM))
            M.require(f"{n}: drives away at least as fast as the ego (10 m/s)", v >= 10 * DM)
        else:  # a slower lead the ego catches up with
            M.require(f"{n}: is 6 to 15 m ahead of the ego at its event", s_te >= int((e.s_event + half + 6.0) * DM))
            M.require(f"{n}: is at most 15 m ahead of the ego at its event", s_te <= int((e.s_event + half + 15.0) * DM))
            M.require(f"{n}: drives slower than the ego (v <= {e.speed_event - 3:.0f} m/s)",
                      v <= int((e.speed_event - 3.0) * DM))
        return
    if a.primitive == "drive_forward" and loc == "behind_same_lane":
        react = REACTION_TIME.get(a.properties.get("driver_state", "attentive"), 1.0)
        M.require(f"{n}: starts behind the ego", s <= int((M.ego_s(0.0) - half - 4.0) * DM))
        if stops:
            M.require(f"{n}: follows at the ego's speed", v == int(e.speed_event * DM))
            gap_need = e.speed_event * react + half + 1.0
            M.require(f"{n}: keeps a gap larger than its reaction distance ({gap_need:.1f} m) so it "
                      "stops behind the ego", s_te <= int((e.s_event - gap_need) * DM))
            M.require(f"{n}: follows within 35 m", s_te >= int((e.s_event - 35.0) * DM))
        else:
            M.require(f"{n}: stays behind the ego at its event", s_te <= int((e.s_event - half - 5.0) * DM))
            M.require(f"{n}: follows within 40 m", s_te >= int((e.s_event - 40.0) * DM))
        return
    if loc == "behind_adjacent_lane":
        M.require(f"{n}: starts behind the ego", s <= int((M.ego_s(0.0) - half - 5.0) * DM))
        M.require(f"{n}: is faster than the ego (v >= {e.speed_event + 2:.0f} m/s)",
                  v >= int((e.speed_event + 2.0) * DM))
        if a.primitive == "cut_in":
            t = M.int(n, "t", 0.0, T)
            M.require(f"{n}: cuts in 0.8 to 2.5 s before the ego's event", t >= int((te - 2.5) * DM))
            M.require(f"{n}: cuts in at least 0.8 s before the ego's event", t <= int((te - 0.8) * DM))
            vt = M.product(n, "vt", v, t, 10 ** 7)
            # at t it must be ahead of the ego: 10 s + v t >= 10 (ego_s(0) + v_e t + half + 3)
            M.require(f"{n}: is ahead of the ego when it cuts in",
                      10 * s + vt >= int((M.ego_s(0.0) + half + 3.0) * 100) + int(e.speed_event * DM) * t)
        else:
            M.require(f"{n}: is close behind the ego at its event (within 25 m)",
                      s_te >= int((e.s_event - 25.0) * DM))
            M.require(f"{n}: has not passed the ego at its event", s_te <= int((e.s_event - half) * DM))
            M.require(f"{n}: passes the ego before the end", 10 * s + v * int(round(T * DM)) >= int((ego_end + half + 5.0) * 100))
        return
    if loc == "ahead_adjacent_lane":
        M.require(f"{n}: is 3 to 30 m ahead of the ego at its event", s_te >= int((e.s_event + half + 3.0) * DM))
        M.require(f"{n}: is at most 30 m ahead of the ego at its event", s_te <= int((e.s_event + half + 30.0) * DM))
        if a.primitive == "change_lane":
            t = M.int(n, "t", 0.0, T)
            M.require(f"{n}: changes lane 1 to 3 s before the ego's event", t >= int((te - 3.0) * DM))
            M.require(f"{n}: changes lane at least 1 s before the ego's event", t <= int((te - 1.0) * DM))
            M.require(f"{n}: is slower than the ego (v <= {e.speed_event - 2:.0f} m/s)",
                      v <= int((e.speed_event - 2.0) * DM))
            M.require(f"{n}: starts ahead of the ego", s >= int((M.ego_s(0.0) + half + 5.0) * DM))
        return
    if loc == "oncoming_lane":
        s_meet = M.m.NewIntVar(-100000, 100000, f"{n}.s_meet")
        M.m.Add(10 * s_meet - 10 * s + v * te_ds >= 0)
        M.m.Add(10 * s_meet - 10 * s + v * te_ds <= 9)
        M.require(f"{n}: meets the ego around its event (within 25 m ahead)", s_meet >= int(e.s_event * DM))
        M.require(f"{n}: meets the ego within 25 m", s_meet <= int((e.s_event + 25.0) * DM))
        return
    raise ValueError(f"{n}: no constraints for {a.primitive} from {loc}")


def _minimise_core(M: _Model, core: list[str], time_limit: float) -> list[str]:
    """Drop constraints from an infeasible core while the rest stays infeasible (deletion
    filter), so the verdict names only constraints that really conflict."""
    keep = list(core)
    for name in list(core):
        trial = [c for c in keep if c != name]
        if not trial:
            continue
        M.m.ClearAssumptions()
        M.m.AddAssumptions([M.lits[c] for c in trial])
        solver = M.cp.CpSolver()
        solver.parameters.max_time_in_seconds = time_limit / 4
        solver.parameters.num_workers = 1
        if solver.Solve(M.m) == M.cp.INFEASIBLE:
            keep = trial
    return keep


def solve(ego: EgoTemplate, actors: list[ActorSpec], *, seed: int = 0, time_limit: float = 2.0) -> Solution:
    """Solve the placement model; an infeasible model names its conflicting constraints."""
    t0 = time.perf_counter()
    M = _Model(ego)
    for a in actors:
        _add_actor(M, a)
    # prefer the middle of each speed class and gaps that are not extreme: minimise distance of
    # speeds from their class centre (deterministic, and avoids boundary solutions)
    terms = []
    for a in actors:
        vv = M.vars.get(a.name, {}).get("v")
        if vv is not None:
            lo, hi = _speed_range(a)
            dev = M.m.NewIntVar(0, 1000, f"{a.name}.vdev")
            M.m.AddAbsEquality(dev, vv - int((lo + hi) / 2 * DM))
            terms.append(dev)
    if terms:
        M.m.Minimize(sum(terms))
    M.m.AddAssumptions(list(M.lits.values()))
    solver = M.cp.CpSolver()
    solver.parameters.max_time_in_seconds = time_limit
    solver.parameters.num_workers = 1  # deterministic and cheap; the models are tiny
    solver.parameters.random_seed = int(seed)
    status = solver.Solve(M.m)
    names = {M.cp.OPTIMAL: "optimal", M.cp.FEASIBLE: "feasible", M.cp.INFEASIBLE: "infeasible",
             M.cp.MODEL_INVALID: "model_invalid"}
    report = SolverReport(status=names.get(status, "unknown"), wall_time=time.perf_counter() - t0)
    if status == M.cp.INFEASIBLE:
        by_index = {lit.Index(): name for name, lit in M.lits.items()}
        core = [by_index[i] for i in solver.SufficientAssumptionsForInfeasibility() if i in by_index]
        report.conflicts = _minimise_core(M, core, time_limit) or ["(no core found)"]
        report.wall_time = time.perf_counter() - t0
        return Solution(report)
    if status not in (M.cp.OPTIMAL, M.cp.FEASIBLE):
        report.conflicts = [f"the solver stopped without a solution ({solver.StatusName(status)})"]
        return Solution(report)
    params: dict[str, dict[str, float]] = {}
    for a in actors:
        vals = {k: solver.Value(var) / DM for k, var in M.vars.get(a.name, {}).items()
                if k in ("s", "v", "t", "d0")}
        params[a.name] = vals
    return Solution(report, params)


def lane_offset(ego: EgoTemplate, a: ActorSpec) -> float:
    """Lateral offset [m] in the ego's frame for an actor's start location."""
    fr = ego.frame
    loc = a.location
    if loc in ("ahead_same_lane", "behind_same_lane", "crosswalk_ahead"):
        return fr.lane_d(ego.ego_lane)
    if loc in ("ahead_adjacent_lane", "behind_adjacent_lane"):
        other = 0 if ego.ego_lane == 1 else 1
        return fr.lane_d(other)
    if loc == "oncoming_lane":
        return fr.lane_d(-1)
    if loc == "roadside_ahead":
        return roadside_d(ego, a.asset, a.size[1], "right")
    if loc == "roadside_opposite_ahead":
        return roadside_d(ego, a.asset, a.size[1], "left")
    return 0.0


__all__ = ["ActorSpec", "Solution", "solve", "lane_offset", "LANE_CHANGE_LENGTH", "JUNCTION_RADIUS"]
