"""CP-SAT: choose start offsets, speeds and trigger times so the causes happen around the ego.

Each actor's primitive (:mod:`regen.driving.primitives`) adds its parameters and named
constraints to one :class:`~regen.driving.world.placement.PlacementModel`; when the model is infeasible,
its minimal conflict set (:meth:`regen.cpsat.NamedModel.solve`) names the constraints in conflict.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from regen.core.scenario import SolverReport
from regen.driving.primitives import find, for_actor
from regen.driving.primitives.base import SPEED_CLASSES
from regen.driving.primitives.shared.attention import couple
from regen.driving.world.actors import ActorSpec, RoleChoice
from regen.driving.world.egos import EgoTemplate
from regen.driving.world.placement import DM, PlacementModel

SOLVED = ("s", "v", "t", "d0")  # the parameters a scenario keeps per actor


@dataclass
class Solution:
    report: SolverReport
    params: dict[str, dict[str, float]] = field(default_factory=dict)  # actor -> s, v, t, d0


def placement_model(ego: EgoTemplate, actors: list[ActorSpec]) -> PlacementModel:
    """The placement model of ``actors`` around ``ego``: every primitive's parameters and named
    constraints, without objective or assumptions (for callers that solve it their own way,
    e.g. :mod:`regen.driving.testing.variants`)."""
    M = PlacementModel(ego)
    for a in actors:
        for_actor(a.asset, a.primitive).constrain(M, a)
    couple(M, actors)  # what one actor's mind does with another's state (a driver at its light)
    return M


def solved_params(M: PlacementModel, value: Callable[[Any], int],
                  actors: list[ActorSpec]) -> dict[str, dict[str, float]]:
    """The :data:`SOLVED` parameters of each actor (metres, m/s, seconds) from a solution;
    ``value`` reads a variable (e.g. ``solver.Value``)."""
    return {a.name: {k: value(var) / DM for k, var in M.vars.get(a.name, {}).items() if k in SOLVED}
            for a in actors}


def solve(ego: EgoTemplate, actors: list[ActorSpec], *, seed: int = 0, time_limit: float = 2.0,
          explain: bool = True) -> Solution:
    """Solve the placement model (``time_limit`` [s] of solver work,
    :func:`regen.cpsat.make_solver`); an infeasible model names its conflicting constraints
    (a minimal set; ``explain=False``, for a caller that reads only the status: the solver's own)."""
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
    out = M.solve(time_limit, seed=int(seed), explain=explain)  # one worker: deterministic; the models are tiny
    report = SolverReport(status=out.status, wall_time=time.perf_counter() - t0)
    if out.status == "infeasible":
        report.conflicts = out.conflicts or ["(no core found)"]
        return Solution(report)
    if not out.solved:
        report.conflicts = [f"the solver stopped without a solution ({out.cp_status})"]
        return Solution(report)
    return Solution(report, solved_params(M, out.value, actors))




def refit_speeds(template: EgoTemplate, roles: list[RoleChoice], sol: Solution,
                 spec_of: Callable[[RoleChoice], ActorSpec], *, seed: int = 0
                 ) -> tuple[list[RoleChoice], Solution, list[str]]:
    """An infeasible placement where a role in conflict moves at a speed class the graph left
    open: the nearest other class that makes it feasible (a car that cuts in in front of an ego
    driving 12 m/s must be fast), one role at a time, said in a fallback note; else unchanged."""
    for i, r in enumerate(roles):
        prim = find(r.primitive) if r.primitive else None
        if "target_speed" in r.fixed or prim is None or not prim.moves:
            continue
        why = "; ".join(c for c in sol.report.conflicts if c.startswith(f"{r.name}:"))
        if not why:
            continue
        here = SPEED_CLASSES.index(r.speed_class)
        for other in sorted((c for c in SPEED_CLASSES if c != r.speed_class),
                            key=lambda c: abs(SPEED_CLASSES.index(c) - here)):
            trial = [*roles[:i], replace(r, speed_class=other), *roles[i + 1:]]
            again = solve(template, [spec_of(t) for t in trial], seed=seed)
            if again.report.status != "infeasible":
                return trial, again, [f"speed class changed to fit the placement: {r.name} {r.speed_class} -> "
                                      f"{other} (its speed was not the graph's; {why})"]
    return roles, sol, []


__all__ = ["refit_speeds", "SOLVED", "ActorSpec", "Solution", "placement_model", "solve", "solved_params"]
