"""Parameter variants of a grounded driving scenario: other points of its CP-SAT feasible set.

A scenario keeps its solved parameters per actor (start offset ``s`` [m], speed ``v`` [m/s],
trigger time ``t`` [s], lateral offset ``d0`` [m]). Variant 0 is the scenario as grounded; the
others come from the same placement model (:func:`regen.driving.grounding.placement.placement_model`, rebuilt
from the scenario's ego template and roles, every named constraint required): each parameter
gets a seeded random target inside its feasible range and CP-SAT finds the feasible point
nearest to the targets that stands apart from every earlier variant (by a tenth of some
parameter's range where the feasible set allows, else by one model unit). ``extremes=True`` (the adversarial
search, :mod:`regen.driving.testing.adversarial`) puts the targets of trigger times and speeds at the
ends of their ranges, where a policy under test is most likely to fail. :func:`variant_near` is
the same solve for targets given as shares of each range (the parameter search of
``regen falsify`` asks for them).

The model is an approximation of the simulation, so a variant is a test only when the scripted
template ego still verifies in it: :func:`check_template` runs the backend's own simulate and
verify stages on it (about a second) and looks for the ego's collisions.
"""

from __future__ import annotations

import hashlib
import logging
import random
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.harness.contract import TemplateRun

log = logging.getLogger(__name__)

EGO = "ego"
SOLVE_TIME = 2.0  # wall-time cap of one solve [s]; the models are tiny
DETERMINISTIC_TIME = 5.0  # CP-SAT's deterministic-time cap, so results do not depend on the machine
TARGET_SCALE = 1000  # each parameter's distance to its target is weighted as a share of its range
SEPARATION = 0.1  # a variant differs from every earlier one by this share of some parameter's range
EXTREME = ("t", "v")  # pushed to the ends of their ranges with extremes=True

Key = tuple[str, str]  # (actor, parameter)


@dataclass
class FeasibleSet:
    """The rebuilt placement model's ingredients and each parameter's feasible range [model units]."""

    template: Any  # regen.driving.world.egos.EgoTemplate
    actors: list[Any]  # regen.driving.world.actors.ActorSpec
    bounds: dict[Key, tuple[int, int]] = field(default_factory=dict)


def _actors(scenario: Scenario) -> tuple[Any, list[Any]]:
    from regen.driving.assets import database
    from regen.driving.grounding.rules import actor_spec, roles_of, template_of

    db = database()
    return template_of(scenario), [actor_spec(r, db) for r in roles_of(scenario)]


def _model(fs: FeasibleSet) -> tuple[Any, dict[Key, Any]]:
    """A fresh model with every named constraint required, and its solved parameters by key."""
    from regen.driving.grounding.placement import SOLVED, placement_model

    M = placement_model(fs.template, fs.actors)
    M.m.AddBoolAnd(list(M.lits.values()))
    keys = {(a, k): var for a, vs in M.vars.items() for k, var in vs.items() if k in SOLVED}
    return M, keys


def _solve(M: Any, seed: int) -> tuple[bool, Any]:
    from regen.cpsat import make_solver

    solver = make_solver(SOLVE_TIME, seed=seed)
    solver.parameters.max_deterministic_time = DETERMINISTIC_TIME
    status = solver.Solve(M.m)
    return status in (M.cp.OPTIMAL, M.cp.FEASIBLE), solver


def feasible_set(scenario: Scenario) -> FeasibleSet | None:
    """The scenario's rebuilt placement model with each parameter's feasible range (two solves
    per parameter: worth keeping for several :func:`variant_near` calls); None when the rebuilt
    model is infeasible."""
    template, actors = _actors(scenario)
    fs = FeasibleSet(template=template, actors=actors)
    M, keys = _model(fs)
    for key, var in sorted(keys.items()):
        ends = []
        for sense in (M.m.Minimize, M.m.Maximize):
            sense(var)
            ok, solver = _solve(M, 0)
            if not ok:
                return None
            ends.append(int(solver.Value(var)))
        fs.bounds[key] = (min(ends), max(ends))
    return fs


def _as_ints(params: dict[str, dict[str, Any]], keys: dict[Key, Any]) -> dict[Key, int]:
    from regen.driving.world.placement import DM

    return {(a, k): int(round(float(params[a][k]) * DM)) for a, k in keys if k in params.get(a, {})}


def _seed(*parts: object) -> int:
    # hashed: random.Random seeded with similar strings gives similar first draws
    return int.from_bytes(hashlib.sha256(":".join(map(str, parts)).encode()).digest()[:8], "big")


def _targets(fs: FeasibleSet, rng: random.Random, extremes: bool) -> dict[Key, int]:
    out = {}
    for key, (lo, hi) in sorted(fs.bounds.items()):
        if extremes and key[1] in EXTREME:
            out[key] = rng.choice((lo, hi))
        else:
            out[key] = rng.randint(lo, hi)
    return out


def _nearest(fs: FeasibleSet, targets: dict[Key, int], avoid: list[dict[Key, int]], seed: int,
             separation: float) -> dict[str, dict[str, float]] | None:
    """The feasible point nearest to ``targets`` (each distance weighted by 1 / its range)
    that differs from every point of ``avoid`` in at least one parameter by ``separation`` of
    its range (at least one model unit); None when there is none."""
    from regen.driving.grounding.placement import solved_params

    M, keys = _model(fs)
    terms = []
    for key, goal in targets.items():
        lo, hi = fs.bounds[key]
        if hi == lo:
            continue
        dev = M.m.NewIntVar(0, hi - lo, f"{key[0]}.{key[1]}.to_target")
        M.m.AddAbsEquality(dev, keys[key] - goal)
        terms.append(max(1, round(TARGET_SCALE / (hi - lo))) * dev)
    for point in avoid:
        differs = []
        for key, value in point.items():
            lo, hi = fs.bounds[key]
            gap = max(1, round(separation * (hi - lo)))
            above, below = M.m.NewBoolVar(""), M.m.NewBoolVar("")
            M.m.Add(keys[key] >= value + gap).OnlyEnforceIf(above)
            M.m.Add(keys[key] <= value - gap).OnlyEnforceIf(below)
            differs += [above, below]
        M.m.AddBoolOr(differs)
    if terms:
        M.m.Minimize(sum(terms))
    ok, solver = _solve(M, seed)
    return solved_params(M, solver.Value, fs.actors) if ok else None


def sample_parameters(scenario: Scenario, n: int, seed: int = 0, *,
                      extremes: bool = False) -> list[dict[str, dict[str, float]]]:
    """Up to ``n`` distinct parameter sets of the scenario's feasible set, the grounded one
    first (fewer when the feasible set has fewer points; only the grounded one when the rebuilt
    model is infeasible). Deterministic for ``seed`` (and the scenario's id)."""
    grounded = {a: dict(p) for a, p in scenario.parameters.items()}
    if n <= 1:
        return [grounded]
    fs = feasible_set(scenario)
    if fs is None:
        log.warning("%s: the rebuilt placement model is infeasible; no variants", scenario.id)
        return [grounded]
    _, keys = _model(fs)
    seen = [_as_ints(grounded, keys)]
    out = [grounded]
    for k in range(1, n):
        rng = random.Random(_seed(seed, scenario.id, k))
        targets = _targets(fs, rng, extremes)
        point = (_nearest(fs, targets, seen, seed, SEPARATION)  # apart, else merely different
                 or _nearest(fs, targets, seen, seed, 0.0))
        if point is None:
            log.info("%s: the feasible set has only %d distinct points", scenario.id, len(out))
            break
        params = {a: {**grounded.get(a, {}), **p} for a, p in point.items()}
        seen.append(_as_ints(params, keys))
        out.append(params)
    return out


def sample_variants(scenario: Scenario, n: int, seed: int = 0, *, extremes: bool = False) -> list[Scenario]:
    """Up to ``n`` variants of a grounded scenario: variant 0 as grounded, the others other
    points of its CP-SAT feasible set (see :func:`sample_parameters`); only their
    ``parameters`` differ."""
    return [scenario if k == 0 else scenario.model_copy(update={"parameters": p}, deep=True)
            for k, p in enumerate(sample_parameters(scenario, n, seed, extremes=extremes))]


def free_parameters(fs: FeasibleSet) -> list[Key]:
    """The (actor, parameter) keys whose feasible range is wider than one model unit's point,
    sorted: the axes of a parameter search."""
    return [key for key, (lo, hi) in sorted(fs.bounds.items()) if hi > lo]


def variant_near(scenario: Scenario, targets: dict[Key, float], seed: int = 0, *,
                 fs: FeasibleSet | None = None) -> Scenario | None:
    """The feasible variant nearest to ``targets``: each key's share of its feasible range (0: its
    lowest feasible value, 1: its highest), each distance weighted by 1 / the range as in
    :func:`sample_parameters`; a free parameter without a target is drawn to its grounded value.
    Only ``parameters`` differ from ``scenario``. None when the rebuilt model is infeasible.
    ``fs``: :func:`feasible_set` of the scenario, when already built."""
    fs = fs if fs is not None else feasible_set(scenario)
    if fs is None:
        return None
    grounded = {a: dict(p) for a, p in scenario.parameters.items()}
    _, keys = _model(fs)
    goals = _as_ints(grounded, keys)
    for key, share in targets.items():
        if key not in fs.bounds:
            raise KeyError(f"{key[0]}.{key[1]} is not a parameter of scenario {scenario.id}")
        lo, hi = fs.bounds[key]
        goals[key] = lo + int(round(min(1.0, max(0.0, float(share))) * (hi - lo)))
    point = _nearest(fs, goals, [], seed, 0.0)
    if point is None:
        return None
    params = {a: {**grounded.get(a, {}), **p} for a, p in point.items()}
    return scenario.model_copy(update={"parameters": params}, deep=True)


def feasible_with(scenario: Scenario, params: dict[str, dict[str, float]]) -> bool:
    """Whether ``params`` satisfy every named constraint of the scenario's placement model."""
    template, actors = _actors(scenario)
    M, keys = _model(FeasibleSet(template=template, actors=actors))
    for key, value in _as_ints(params, keys).items():
        M.m.Add(keys[key] == value)
    return _solve(M, 0)[0]


def ego_collisions(trace: Trace) -> list[str]:
    from regen.driving.verify.collisions import analyze

    return [e.describe() for e in analyze(trace, ego=EGO).collisions if EGO in e.actors]


def check_template(scenario: Scenario) -> TemplateRun:
    """Simulate and verify a variant with its scripted template ego, as ``regen generate`` does
    (the domain backend's stages), without writing a scenario folder."""
    from regen import domains

    backend = domains.make(scenario.domain)
    try:
        with tempfile.TemporaryDirectory(prefix="regen-variant-") as tmp:
            sim = backend.simulate(scenario, Path(tmp))
        verdict, judged = backend.verify(scenario, sim.trace)
    except Exception as exc:  # as the pipeline's simulate stage: any failure is this variant's
        return TemplateRun(verdict=None, trace=None, judged=scenario, error=f"{type(exc).__name__}: {exc}")
    return TemplateRun(verdict=verdict, trace=sim.trace, judged=judged, collisions=ego_collisions(sim.trace))


__all__ = ["FeasibleSet", "TemplateRun", "check_template", "ego_collisions", "feasible_set", "feasible_with",
           "free_parameters", "sample_parameters", "sample_variants", "variant_near"]
