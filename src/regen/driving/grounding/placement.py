"""CP-SAT: choose start offsets, speeds and trigger times so the causes happen around the ego.

Each actor's primitive (:mod:`regen.driving.primitives`) adds its parameters and named
constraints to one :class:`~regen.driving.world.placement.PlacementModel`; when the model is infeasible,
the solver's sufficient assumptions, minimised, name the constraints in conflict.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from regen.core.scenario import SolverReport
from regen.cpsat import make_solver
from regen.driving.primitives import for_actor
from regen.driving.world.actors import ActorSpec
from regen.driving.world.ego import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel

SOLVED = ("s", "v", "t", "d0")  # the parameters a scenario keeps per actor


@dataclass
class Solution:
    report: SolverReport
    params: dict[str, dict[str, float]] = field(default_factory=dict)  # actor -> s, v, t, d0


def _minimise_core(M: PlacementModel, core: list[str], time_limit: float) -> list[str]:
    """Drop constraints from an infeasible core while the rest stays infeasible (deletion
    filter), so the verdict names only constraints that really conflict."""
    keep = list(core)
    for name in list(core):
        trial = [c for c in keep if c != name]
        if not trial:
            continue
        M.m.ClearAssumptions()
        M.m.AddAssumptions([M.lits[c] for c in trial])
        solver = make_solver(time_limit / 4)
        if solver.Solve(M.m) == M.cp.INFEASIBLE:
            keep = trial
    return keep


def placement_model(ego: EgoTemplate, actors: list[ActorSpec]) -> PlacementModel:
    """The placement model of ``actors`` around ``ego``: every primitive's parameters and named
    constraints, without objective or assumptions (for callers that solve it their own way,
    e.g. :mod:`regen.driving.testing.variants`)."""
    M = PlacementModel(ego)
    for a in actors:
        for_actor(a.asset, a.primitive).constrain(M, a)
    return M


def solved_params(M: PlacementModel, value: Callable[[Any], int],
                  actors: list[ActorSpec]) -> dict[str, dict[str, float]]:
    """The :data:`SOLVED` parameters of each actor (metres, m/s, seconds) from a solution;
    ``value`` reads a variable (e.g. ``solver.Value``)."""
    return {a.name: {k: value(var) / DM for k, var in M.vars.get(a.name, {}).items() if k in SOLVED}
            for a in actors}


def solve(ego: EgoTemplate, actors: list[ActorSpec], *, seed: int = 0, time_limit: float = 2.0) -> Solution:
    """Solve the placement model (``time_limit`` [s]); an infeasible model names its
    conflicting constraints."""
    t0 = time.perf_counter()
    M = placement_model(ego, actors)
    specs = [for_actor(a.asset, a.primitive) for a in actors]
    # prefer the middle of each speed class and gaps that are not extreme: minimise distance of
    # speeds from their class centre (deterministic, and avoids boundary solutions)
    terms = []
    for a, spec in zip(actors, specs, strict=True):
        vv = M.vars.get(a.name, {}).get("v")
        if vv is not None:
            lo, hi = spec.speed_range(a)
            dev = M.m.NewIntVar(0, 1000, f"{a.name}.vdev")
            M.m.AddAbsEquality(dev, vv - int((lo + hi) / 2 * DM))
            terms.append(dev)
    if terms:
        M.m.Minimize(sum(terms))
    M.m.AddAssumptions(list(M.lits.values()))
    solver = make_solver(time_limit, seed=int(seed))  # one worker: deterministic; the models are tiny
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
    return Solution(report, solved_params(M, solver.Value, actors))


__all__ = ["SOLVED", "ActorSpec", "Solution", "placement_model", "solve", "solved_params"]
