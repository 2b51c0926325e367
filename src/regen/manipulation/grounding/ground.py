"""Ground a manipulation cause path into a :class:`Scenario` (paper 2.2, manipulation).

The behavior stays fixed (a reward function the robot already has); the path supplies the
purpose and the context objects. The model writes a narrative and chooses, per context object,
one relation from :data:`regen.manipulation.grounding.placement.RELATIONS` to a scene reference
(:mod:`regen.manipulation.grounding.answers`). Its answer is data: names are checked against the
scene, and anything missing or invalid falls back to documented rules
(:data:`~regen.manipulation.grounding.answers.RULES`), each fallback said in
``scenario.fallbacks``. Only a bad answer falls back: a model that cannot be asked (replay cache
miss, provider unreachable, missing key or model file) is an error for the caller. CP-SAT then
solves the positions; what it had to change is said in ``scenario.solver.relaxations``. The FSM
is assembled from the predicate library (:mod:`regen.manipulation.grounding.fsm`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from regen.assets.database import AssetDatabase
from regen.core.graph import CausePath
from regen.core.scenario import Entity, Scenario, SolverReport
from regen.errors import ConfigError, GroundingError
from regen.manipulation.assets import database as manipulation_database
from regen.manipulation.grounding.answers import (
    ContextObject,
    choose_relations,
    reference_name,
    rule_choice,
)
from regen.manipulation.grounding.fsm import build_fsm
from regen.manipulation.grounding.placement import (
    TABLE_XY,
    PlacementResult,
    Request,
    SceneGeometry,
    scene_geometry,
    solve_placement,
    structural_problems,
)
from regen.manipulation.world.furniture import AABB, furniture
from regen.manipulation.world.setting import ManipulationParams, ManipulationWorld
from regen.manipulation.world.tasks import ITEM_ASSETS, BehaviorDef, resolve

log = logging.getLogger(__name__)

DURATION = 12.0  # [s] simulated time cap of one rollout
MAX_OBJECTS = 6  # context objects per scenario


@dataclass
class Cast:
    """Who is in the scene besides the robot, the table and the furniture."""

    item_asset: str | None = None  # what the robot moves (None: nothing, or the carried furniture)
    context: list[ContextObject] = field(default_factory=list)
    powers: dict[str, str] = field(default_factory=dict)  # asset -> the power state the graph chose
    item_size: tuple[float, float, float] | None = None  # [m]

    @property
    def item_name(self) -> str | None:
        return f"{self.item_asset}_item" if self.item_asset else None


def ground_path(path: CausePath, llm: object | None = None, *, seed: int = 0, relax: bool = True,
                choices: dict[str, tuple[str, str]] | None = None) -> Scenario:
    """Turn a manipulation cause path into a scenario with solved placements and an FSM.

    ``llm``: a :class:`regen.llm.LLM` (or None: rules only). A malformed answer
    (:class:`regen.errors.MalformedAnswerError`) or a choice that names no object, relation or
    reference of this scene is replaced by the rules and said in ``scenario.fallbacks``; every
    other model error (:class:`regen.errors.CacheMissError` in replay mode, an unreachable
    provider, a missing key or model file) propagates unchanged. ``choices``: explicit
    ``{entity name: (relation, reference)}`` that override the model and the rules (tests,
    users). ``relax``: when the chosen relations cannot all hold, retry the conflicting objects
    with the rules and record what changed in ``solver.relaxations``; with ``relax=False`` an
    infeasible placement is returned as is (``solver.status == 'infeasible'`` and the reason in
    ``solver.conflicts``).
    """
    if path.behavior.domain != "manipulation":
        raise ConfigError(f"the path's behavior is a {path.behavior.domain} behavior, not manipulation")
    behavior = resolve(ManipulationParams.of(path.behavior).reward, path.behavior.text)
    fname = f"{behavior.furniture}1"
    relaxations: list[str] = []  # placement changes: skipped or dropped objects, relaxed relations
    fallbacks: list[str] = []  # what the rules wrote because the model's answer was unusable
    cast = collect_cast(path, behavior, manipulation_database(), relaxations)
    item_box = None
    if behavior.item is not None:
        item_box = _item_box(behavior, cast.item_size or behavior.item.size)[0]
    geometry = scene_geometry(behavior, fname, item_box)
    narrative, chosen = choose_relations(llm, path, behavior, geometry, cast.context, fname,
                                         choices=choices, relax=relax, fallbacks=fallbacks)
    requests = [Request(n, a, s, *chosen[n]) for n, a, s in cast.context]
    result = solve_placement(requests, geometry, seed=seed)
    if result.status == "infeasible" and relax:
        result, requests = _relax(result, requests, behavior, geometry, seed, relaxations, fname)
    if not narrative:
        narrative = _narrative(path, behavior, requests)
    return _scenario(path, behavior, fname, cast, requests, result, narrative, relaxations,
                     fallbacks, seed)


def collect_cast(path: CausePath, behavior: BehaviorDef, db: AssetDatabase, relaxations: list[str]) -> Cast:
    """The item (if the path names one that fits) and the context objects of the path's
    entities, one of each asset, at most :data:`MAX_OBJECTS`; what was left out is appended to
    ``relaxations``."""
    cast = Cast(item_asset=behavior.item.asset if behavior.item and behavior.script != "carry" else None)
    counts: dict[str, int] = {}
    substituted = False
    for pe in path.entities:
        asset = pe.asset
        if asset not in db.assets:
            relaxations.append(f"skipped {asset!r}: not in the manipulation asset database")
            continue
        if asset in (behavior.asset, behavior.furniture):
            continue  # the behavior's own furniture
        if db.category_of(asset) == "articulated objects":
            relaxations.append(f"skipped {asset!r}: only the behavior's own articulated object is "
                               "simulated")
            continue
        if not substituted and _can_be_the_item(behavior, asset, db):
            cast.item_asset, substituted = asset, True
            continue
        counts[asset] = counts.get(asset, 0) + 1
        power = pe.properties.get("power") if "power" in db.parameters_of(asset) else None
        if power and power[0] in (db.properties["power"].states or ()):
            cast.powers.setdefault(asset, power[0])  # the graph's choice: a tv that is on shows its screen lit
        if any(a == asset for _, a, _ in cast.context):
            continue  # one of each: the path often names an entity for several events
        cast.context.append((f"{asset}{counts[asset]}", asset, tuple(db.assets[asset].size)))
    if len(cast.context) > MAX_OBJECTS:
        relaxations.append(f"kept the first {MAX_OBJECTS} of {len(cast.context)} context objects")
        cast.context = cast.context[:MAX_OBJECTS]
    if cast.item_asset:
        cast.item_size = _item_size(behavior, cast.item_asset, db)
    return cast


def _can_be_the_item(behavior: BehaviorDef, asset: str, db: AssetDatabase) -> bool:
    """Whether a path entity can stand in for a pick-and-place behavior's default item."""
    if not (behavior.item and behavior.script == "pick_place" and asset in ITEM_ASSETS):
        return False
    spec = furniture(behavior.furniture)
    size = tuple(db.assets[asset].size)
    cav = spec.cavity.size if spec.cavity else (0, 0, 0)
    # a side grasp inside the fridge needs something standing up
    upright = behavior.furniture != "fridge" or size[2] >= 0.08
    fits = all(s <= c for s, c in zip(size, cav, strict=True)) or behavior.item.start == "floor"
    return fits and upright


def _item_size(behavior: BehaviorDef, asset: str, db: AssetDatabase) -> tuple[float, float, float]:
    assert behavior.item is not None
    if asset == behavior.item.asset or asset not in db.assets:
        return behavior.item.size
    return tuple(db.assets[asset].size)  # type: ignore[return-value]


def _item_box(behavior: BehaviorDef, size: tuple[float, float, float]) -> tuple[AABB, float, float, float]:
    """Where the behavior's item starts: (floor box for keep-out, x, y, z) [m]."""
    assert behavior.item is not None
    spec = furniture(behavior.furniture)
    fx, fy = behavior.pose
    if behavior.item.start == "cavity" and spec.cavity is not None:
        c = spec.cavity
        # near the front of the interior, where the hand can get at it
        x = fx + c.lo[0] + max(size[0] / 2 + 0.03, 0.06)
        y = fy + (c.lo[1] + c.hi[1]) / 2
        z = c.lo[2]
    elif behavior.script == "carry":
        x, y, z = fx, fy, 0.0
    else:
        x, y = behavior.item.start_xy
        z = 0.0
    box = AABB((x - size[0] / 2, y - size[1] / 2, z), (x + size[0] / 2, y + size[1] / 2, z + size[2]))
    return box, x, y, z


def _relax(result: PlacementResult, requests: list[Request], behavior: BehaviorDef, geometry: SceneGeometry,
           seed: int, relaxations: list[str], fname: str) -> tuple[PlacementResult, list[Request]]:
    """Replace each object named in the conflict by its rule choice, then by 'out of reach'."""
    text = " ".join(result.conflicts)
    changed = []
    for r in requests:
        if r.name in text.split() or f"{r.name} " in text:
            rel, ref = rule_choice(behavior, r.asset, r.size)
            ref = reference_name(ref, fname)
            if (rel, ref) == (r.relation, r.reference) or structural_problems(
                    Request(r.name, r.asset, r.size, rel, ref), geometry.refs):
                rel, ref = "out_of_reach", "robot"
            changed.append(f"{r.name}: {r.relation} {r.reference} -> {rel} {ref}")
            r.relation, r.reference = rel, ref
    if not changed:
        return result, requests
    retry = solve_placement(requests, geometry, seed=seed)
    if retry.status in ("optimal", "feasible"):
        relaxations.append("relaxed infeasible placement (" + "; ".join(result.conflicts) + "): "
                           + ", ".join(changed))
        return retry, requests
    retry.conflicts = result.conflicts + retry.conflicts
    return retry, requests


def _narrative(path: CausePath, behavior: BehaviorDef, requests: list[Request]) -> str:
    causes = [e for e in path.events[:-1]]
    why = " and ".join(causes) if causes else "it was asked to"
    where = "; ".join(f"the {r.asset.replace('_', ' ')} is {r.relation.replace('_', ' ')} the "
                      f"{r.reference}" for r in requests)
    text = f"Because {why}, {path.behavior.text}."
    return f"{text} Setting: {where}." if where else text


def _scenario(path: CausePath, behavior: BehaviorDef, fname: str, cast: Cast, requests: list[Request],
              result: PlacementResult, narrative: str, relaxations: list[str], fallbacks: list[str],
              seed: int) -> Scenario:
    entities, params = _fixed_entities(behavior, fname, cast)
    for r in requests:
        power = cast.powers.get(r.asset)
        entities.append(Entity(name=r.name, asset=r.asset, kind="object",
                               properties={"role": "context", "location": f"{r.relation} {r.reference}",
                                           **({"power": power} if power else {})},
                               behavior="stationary", behavior_params={"relation": r.relation,
                                                                       "reference": r.reference}))
        p = result.placed.get(r.name)
        if p is not None:
            params[r.name] = {"x": round(p.x, 3), "y": round(p.y, 3), "z": round(p.z, 3),
                              "length": r.size[0], "width": r.size[1], "height": r.size[2],
                              "dynamic": p.dynamic, "relation": r.relation, "reference": r.reference,
                              "support": p.support, **({"power": power} if power else {})}
    fsm = build_fsm(behavior, fname, cast.item_name, requests)
    status = result.status if result.status in ("optimal", "feasible", "infeasible", "model_invalid",
                                                 "unknown") else "unknown"
    solver = SolverReport(status=status, wall_time=round(result.wall_time, 4),
                          conflicts=list(result.conflicts), relaxations=relaxations)
    try:
        return Scenario(id=f"manip-{behavior.id}-{path.key}-s{seed}", domain="manipulation",
                        behavior=path.behavior, causal_graph=list(path.events), narrative=narrative,
                        entities=entities, fsm=fsm, parameters=params,
                        world=ManipulationWorld(behavior=behavior.id, duration=DURATION, seed=seed,
                                                simulator="pybullet").as_world(),
                        solver=solver, fallbacks=fallbacks)
    except ValueError as exc:
        raise GroundingError(f"the grounded scenario is inconsistent: {exc}") from exc


def _fixed_entities(behavior: BehaviorDef, fname: str, cast: Cast) -> tuple[list[Entity], dict[str, dict]]:
    """The robot, the behavior's furniture, the table and the item, with their parameters."""
    fx, fy = behavior.pose
    entities = [Entity(name="robot", asset="franka_panda", kind="robot", properties={"role": "robot"},
                       behavior=behavior.id),
                Entity(name=fname, asset=behavior.asset, kind="object",
                       properties={"role": "target", "articulation": _articulation(behavior)},
                       behavior="stationary")]
    params: dict[str, dict] = {fname: {"x": fx, "y": fy, "furniture": behavior.furniture,
                                       "fraction": behavior.start_fraction}}
    tx, ty = TABLE_XY
    entities.append(Entity(name="table", asset="table", kind="object", properties={"role": "support"},
                           behavior="stationary"))
    params["table"] = {"x": tx, "y": ty, "furniture": "table", "fraction": 0.0}
    item_name, item_size = cast.item_name, cast.item_size
    if item_name:
        assert behavior.item is not None and item_size is not None
        _box, ix, iy, iz = _item_box(behavior, item_size)
        entities.append(Entity(name=item_name, asset=cast.item_asset, kind="object",
                               properties={"role": "item"}, behavior="stationary"))
        params[item_name] = {"x": ix, "y": iy, "z": iz, "length": item_size[0],
                             "width": item_size[1], "height": item_size[2], "dynamic": True}
    return entities, params


def _articulation(behavior: BehaviorDef) -> str:
    if behavior.start_fraction <= 0.05:
        return "closed"
    return "open" if behavior.start_fraction >= 0.75 else "half_open"


__all__ = ["DURATION", "MAX_OBJECTS", "Cast", "collect_cast", "ground_path"]
