"""Placement variants of a grounded manipulation scenario: other points of its CP-SAT feasible set.

A scenario keeps each context object's relation (``pet1 outside door1``) and its solved
position. Variant 0 is the scenario as grounded; the others re-solve the same placement model
(:func:`regen.manipulation.grounding.placement.solve_placement` over the scene geometry the grounding
used, every relation required, nothing relaxed) with other seeded preferred spots, and keep a
solution only when some object stands at least :data:`SEPARATION` away from where it stands in
every earlier variant. ``extremes=True`` puts the preferred spots at the room's corners, so the
objects go to the edges of their feasible regions. Only the context objects' ``x``, ``y``,
``z`` (and ``dynamic``, ``support``) change; the task furniture and item stay as grounded.
:func:`variant_near` is the same solve with preferred spots given as shares of the room's floor
(the parameter search of ``regen falsify`` asks for them).
"""

from __future__ import annotations

import hashlib
import logging
import random

from regen.core.scenario import Scenario
from regen.manipulation.grounding.placement import ROOM, Request, scene_geometry, solve_placement
from regen.manipulation.world.furniture import AABB
from regen.manipulation.world.setting import ManipulationWorld
from regen.manipulation.world.tasks import get_behavior

log = logging.getLogger(__name__)

SEPARATION = 0.05  # [m] a variant moves some object at least this far from every earlier variant
TRIES = 6  # solves per wanted variant before giving up (the feasible set may be small)
SOLVE_TIME = 2.0  # [s] wall-time cap of one solve


def _seed(*parts: object) -> int:
    # hashed: random.Random seeded with similar integers gives similar first draws
    return int.from_bytes(hashlib.sha256(":".join(map(str, parts)).encode()).digest()[:4], "big")


def placement_requests(scenario: Scenario) -> tuple[list[Request], object]:
    """The context objects' placement requests and the scene geometry they were solved in."""
    behavior = get_behavior(ManipulationWorld.of(scenario).behavior)
    target = next(e.name for e in scenario.entities if e.properties.get("role") == "target")
    item_box = None
    for e in scenario.entities:
        p = scenario.parameters.get(e.name, {})
        if e.properties.get("role") == "item" and "length" in p:
            lo = (p["x"] - p["length"] / 2, p["y"] - p["width"] / 2, p.get("z", 0.0))
            item_box = AABB(lo, (lo[0] + p["length"], lo[1] + p["width"], lo[2] + p["height"]))
    requests = [Request(e.name, e.asset, (p["length"], p["width"], p["height"]), p["relation"], p["reference"])
                for e in scenario.entities if e.properties.get("role") == "context"
                for p in [scenario.parameters.get(e.name, {})] if "relation" in p]
    return requests, scene_geometry(behavior, target, item_box)


def _placed(scenario: Scenario, placed: dict) -> Scenario:
    """The scenario with its context objects where a solve ``placed`` them."""
    params = {a: dict(v) for a, v in scenario.parameters.items()}
    for name, p in placed.items():
        params[name].update(x=round(p.x, 3), y=round(p.y, 3), z=round(p.z, 3), dynamic=p.dynamic,
                            support=p.support)
    return scenario.model_copy(update={"parameters": params}, deep=True)


def _apart(point: dict[str, tuple[float, float]], seen: list[dict[str, tuple[float, float]]]) -> bool:
    return all(any(max(abs(x - old[n][0]), abs(y - old[n][1])) >= SEPARATION - 1e-9
                   for n, (x, y) in point.items() if n in old) for old in seen)


def sample_variants(scenario: Scenario, n: int, seed: int = 0, *, extremes: bool = False) -> list[Scenario]:
    """Up to ``n`` variants, the scenario as grounded first (fewer when the feasible set has
    fewer distinct points, or none but the grounded one when nothing is placed). Deterministic
    for ``seed`` and the scenario's id."""
    out = [scenario]
    if n <= 1:
        return out
    requests, geometry = placement_requests(scenario)
    if not requests:
        return out
    seen = [{r.name: (scenario.parameters[r.name]["x"], scenario.parameters[r.name]["y"]) for r in requests}]
    corners = [(ROOM.lo[0], ROOM.lo[1]), (ROOM.lo[0], ROOM.hi[1]), (ROOM.hi[0], ROOM.lo[1]), (ROOM.hi[0], ROOM.hi[1])]
    for attempt in range(1, TRIES * n):
        if len(out) >= n:
            break
        k = _seed(seed, scenario.id, attempt)
        rng = random.Random(k)
        spots = {r.name: rng.choice(corners) for r in requests} if extremes else None
        res = solve_placement(requests, geometry, seed=k % 2**31, time_limit=SOLVE_TIME, spots=spots)
        if res.status not in ("optimal", "feasible"):
            continue
        point = {name: (round(p.x, 3), round(p.y, 3)) for name, p in res.placed.items()}
        if not _apart(point, seen):
            continue
        seen.append(point)
        out.append(_placed(scenario, res.placed))
    if len(out) < n:
        log.info("%s: %d distinct placements found of %d asked", scenario.id, len(out), n)
    return out


def parameter_keys(scenario: Scenario) -> list[tuple[str, str]]:
    """Each context object's ``x`` and ``y``, in the scenario's order: what
    :func:`variant_near` takes targets for."""
    requests, _ = placement_requests(scenario)
    return [(r.name, axis) for r in requests for axis in ("x", "y")]


def _spot(scenario: Scenario, targets: dict[tuple[str, str], float], name: str, axis: int) -> float:
    """The room coordinate [m] a unit target asks for along ``axis`` (0: x, 1: y), else where the
    object stands."""
    share = targets.get((name, "xy"[axis]))
    if share is None:
        return float(scenario.parameters[name]["xy"[axis]])
    return ROOM.lo[axis] + min(1.0, max(0.0, float(share))) * (ROOM.hi[axis] - ROOM.lo[axis])


def variant_near(scenario: Scenario, targets: dict[tuple[str, str], float], seed: int = 0) -> Scenario | None:
    """The feasible placement nearest to ``targets``: each object's ``x`` and ``y`` as shares of
    the room's floor (:data:`~regen.manipulation.grounding.placement.ROOM`: 0 its low edge, 1
    its high edge), the object's grounded coordinate where a target is missing; the same solve
    as :func:`sample_variants` with these preferred spots, every relation required. None when no
    placement satisfies them (or the scenario places nothing)."""
    requests, geometry = placement_requests(scenario)
    if not requests:
        return None
    known = {r.name for r in requests}
    unknown = sorted(f"{a}.{k}" for a, k in targets if a not in known or k not in ("x", "y"))
    if unknown:
        raise KeyError(f"not placement parameters of scenario {scenario.id}: {', '.join(unknown)}")
    spots = {r.name: (_spot(scenario, targets, r.name, 0), _spot(scenario, targets, r.name, 1))
             for r in requests}
    res = solve_placement(requests, geometry, seed=seed % 2**31, time_limit=SOLVE_TIME, spots=spots)
    if res.status not in ("optimal", "feasible"):
        return None
    return _placed(scenario, res.placed)


__all__ = ["SEPARATION", "parameter_keys", "placement_requests", "sample_variants", "variant_near"]
