"""Ground a manipulation cause path into a :class:`Scenario` (paper 2.2, manipulation).

The behavior stays fixed (a reward function the robot already has); the path supplies the
purpose and the context objects. The model writes a narrative and chooses, per context object,
one relation from :data:`regen.manipulation.placement.RELATIONS` to a scene reference. Its answer
is data: names are checked against the scene, and anything missing or invalid falls back to
documented rules (:data:`RULES`), each fallback said in ``scenario.fallbacks``. Only a bad answer
falls back: a model that cannot be asked (replay cache miss, provider unreachable, missing key or
model file) is an error for the caller. CP-SAT then solves the positions; what it had to change
is said in ``scenario.solver.relaxations``. The FSM is assembled from the predicate library:
stage 1 the context holds and the furniture is in its initial state, stage 2 the hand reaches
the handle (or item), stage 3 the behavior's success predicates hold while the context still
holds.
"""

from __future__ import annotations

import logging

from pydantic import Field

from regen.assets.database import AssetDatabase
from regen.core.base import Answer
from regen.core.graph import CausePath
from regen.core.scenario import (
    FSM,
    AbstractState,
    Entity,
    PredicateCall,
    Scenario,
    SolverReport,
    Stage,
    StateRef,
)
from regen.errors import ConfigError, GroundingError, MalformedAnswerError
from regen.manipulation.assets import database as manipulation_database
from regen.manipulation.behaviors import ITEM_ASSETS, BehaviorDef, resolve
from regen.manipulation.placement import (
    RELATIONS,
    TABLE_XY,
    PlacementResult,
    Request,
    describe_geometry,
    scene_geometry,
    solve_placement,
    structural_problems,
)
from regen.manipulation.setting import ManipulationParams, ManipulationWorld
from regen.manipulation.urdf import AABB, furniture
from regen.templates import environment

log = logging.getLogger(__name__)

DURATION = 12.0  # [s] simulated time cap of one rollout
MAX_OBJECTS = 6  # context objects per scenario


class PlacementChoice(Answer):
    object: str = Field(description="name of the object to place")
    relation: str = Field(description="one relation from the list")
    reference: str = Field(description="robot, table or the furniture's name")


class GroundAnswer(Answer):
    narrative: str = Field(description="one or two sentences: why the robot does this")
    placements: list[PlacementChoice] = Field(default_factory=list)


# Rule-based placement: (behavior id or '*', asset) -> (relation, reference), where 'F' is the
# behavior's furniture. Used when the model gives no usable choice for an object.
RULES: dict[tuple[str, str], tuple[str, str]] = {
    ("open_door", "pet"): ("outside", "F"), ("open_door", "adult"): ("outside", "F"),
    ("open_door", "child"): ("outside", "F"), ("close_window", "pet"): ("near", "F"),
    ("close_window", "plant"): ("on", "table"), ("adjust_faucet", "dishes"): ("in", "F"),
    ("adjust_faucet", "cup"): ("in", "F"), ("adjust_faucet", "fruit"): ("in", "F"),
    ("adjust_faucet", "plant"): ("near", "F"), ("turn_oven_knob", "frozen_vegetables"): ("on", "F"),
    ("turn_oven_knob", "dishes"): ("on", "F"), ("pull_drawer", "clothes"): ("in", "F"),
    ("pull_drawer", "book"): ("in", "F"), ("open_cabinet", "cup"): ("in", "F"),
    ("open_cabinet", "dishes"): ("in", "F"), ("open_cabinet", "bottle"): ("in", "F"),
    ("tilt_display", "adult"): ("near", "table"), ("tilt_display", "laptop"): ("on", "table"),
    ("*", "trash_can"): ("right_of", "F"), ("*", "adult"): ("near", "table"),
    ("*", "child"): ("near", "table"), ("*", "pet"): ("left_of", "F"),
    ("*", "plant"): ("near", "table"), ("*", "tv"): ("on", "table"),
    ("open_door", "visitor"): ("outside", "F"), ("*", "visitor"): ("near", "table"),
    ("*", "spill"): ("near", "F"), ("*", "mop"): ("left_of", "F"),
    # the carried bucket leaves its place: what it is carried for stays by the table
    ("carry_bucket", "spill"): ("near", "table"), ("carry_bucket", "mop"): ("near", "table"),
    ("*", "ingredients"): ("on", "table"),
}


def rule_choice(behavior: BehaviorDef, asset: str, size: tuple[float, float, float]) -> tuple[str, str]:
    """The documented default relation of an asset in a behavior's scene."""
    for key in ((behavior.id, asset), ("*", asset)):
        if key in RULES:
            return RULES[key]
    if max(size[:2]) <= 0.35 and size[2] <= 0.45:
        return ("on", "table")
    return ("near", "table")


def _ref_name(ref: str, furniture_name: str) -> str:
    return furniture_name if ref == "F" else ref


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
    db = manipulation_database()
    fname = f"{behavior.furniture}1"
    relaxations: list[str] = []  # placement changes: skipped or dropped objects, relaxed relations
    fallbacks: list[str] = []  # what the rules wrote because the model's answer was unusable

    # --- entities: the item (if the path names one that fits) and the context objects -------
    item_asset = behavior.item.asset if behavior.item and behavior.script != "carry" else None
    context: list[tuple[str, str, tuple[float, float, float]]] = []
    counts: dict[str, int] = {}
    powers: dict[str, str] = {}  # asset -> the power state the graph chose for it
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
        if (behavior.item and behavior.script == "pick_place" and not substituted
                and asset in ITEM_ASSETS):
            spec = furniture(behavior.furniture)
            size = tuple(db.assets[asset].size)
            cav = spec.cavity.size if spec.cavity else (0, 0, 0)
            # a side grasp inside the fridge needs something standing up
            upright = behavior.furniture != "fridge" or size[2] >= 0.08
            fits = all(s <= c for s, c in zip(size, cav, strict=True)) or behavior.item.start == "floor"
            if fits and upright:
                item_asset, substituted = asset, True
                continue
        counts[asset] = counts.get(asset, 0) + 1
        power = pe.properties.get("power") if "power" in db.parameters_of(asset) else None
        if power and power[0] in (db.properties["power"].states or ()):
            powers.setdefault(asset, power[0])  # the graph's choice: a tv that is on shows its screen lit
        if any(a == asset for _, a, _ in context):
            continue  # one of each: the path often names an entity for several events
        context.append((f"{asset}{counts[asset]}", asset, tuple(db.assets[asset].size)))
    if len(context) > MAX_OBJECTS:
        relaxations.append(f"kept the first {MAX_OBJECTS} of {len(context)} context objects")
        context = context[:MAX_OBJECTS]
    item_name = f"{item_asset}_item" if item_asset else None
    item_size = _item_size(behavior, item_asset, db) if item_asset else None
    item_box = None
    if behavior.item is not None:
        size = item_size or behavior.item.size
        item_box, ix, iy, iz = _item_box(behavior, size)
    geometry = scene_geometry(behavior, fname, item_box)

    # --- the model's choices, validated; rules for the rest --------------------------------
    narrative = ""
    chosen: dict[str, tuple[str, str]] = {}
    if llm is not None and context:
        sizes = {n: s for n, _, s in context}
        answered: set[str] = set()  # objects the model gave any choice for
        try:
            answer: GroundAnswer | None = _ask(llm, path, behavior, geometry, context)
        except MalformedAnswerError as exc:
            # only a bad answer falls back; a model that cannot be asked is the caller's error
            answer = None
            fallbacks.append(f"model answer unusable ({exc}); used the rules")
        if answer is not None:
            narrative = " ".join(answer.narrative.split())[:600]
            if not narrative:
                fallbacks.append("model narrative empty; used the rule narrative")
            for pc in answer.placements:
                answered.add(pc.object)
                ref = _ref_name(pc.reference.strip(), fname)
                if pc.object in sizes and pc.relation in RELATIONS and ref in geometry.refs:
                    req = Request(pc.object, "", sizes[pc.object], pc.relation, ref)
                    problems = structural_problems(req, geometry.refs)
                    if problems and relax:
                        fallbacks.append(f"model choice rejected: {problems[0]}")
                        continue
                    chosen.setdefault(pc.object, (pc.relation, ref))
                else:
                    fallbacks.append(f"model choice ignored: {pc.object} {pc.relation} {pc.reference}")
            missing = [n for n in sizes if n not in answered and not (choices and n in choices)]
            if missing:
                fallbacks.append(f"model gave no placement for {', '.join(missing)}; used the rules")
    for name, asset, size in context:
        if choices and name in choices:
            chosen[name] = (choices[name][0], _ref_name(choices[name][1], fname))
        elif name not in chosen:
            rel, ref = rule_choice(behavior, asset, size)
            chosen[name] = (rel, _ref_name(ref, fname))
    requests = [Request(n, a, s, *chosen[n]) for n, a, s in context]
    result = solve_placement(requests, geometry, seed=seed)
    if result.status == "infeasible" and relax:
        result, requests = _relax(result, requests, behavior, geometry, seed, relaxations, fname)
    if not narrative:
        narrative = _narrative(path, behavior, requests)
    return _scenario(path, behavior, fname, item_name, item_asset, item_size, geometry, requests,
                     result, narrative, relaxations, fallbacks, seed, powers)


def _ask(llm: object, path: CausePath, behavior: BehaviorDef, geometry, context) -> GroundAnswer:
    db = manipulation_database()
    prompt = environment("regen.manipulation").get_template("ground.j2").render(
        behavior=path.behavior.text, events=path.events, references=describe_geometry(geometry),
        objects=[{"name": n, "description": db.assets[a].description, "size": s}
                 for n, a, s in context],
        relations=RELATIONS, reference_names=list(geometry.refs))
    return llm.structured(prompt, GroundAnswer, purpose="ground")  # type: ignore[attr-defined]


def _relax(result: PlacementResult, requests: list[Request], behavior: BehaviorDef, geometry,
           seed: int, relaxations: list[str], fname: str) -> tuple[PlacementResult, list[Request]]:
    """Replace each object named in the conflict by its rule choice, then by 'out of reach'."""
    text = " ".join(result.conflicts)
    changed = []
    for r in requests:
        if r.name in text.split() or f"{r.name} " in text:
            rel, ref = rule_choice(behavior, r.asset, r.size)
            ref = _ref_name(ref, fname)
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


_PRED = {"on": "on", "in": "inside", "under": "under", "near": "near", "left_of": "left_of",
         "right_of": "right_of", "in_front_of": "in_front_of", "behind": "behind",
         "outside": "outside", "out_of_reach": "out_of_reach"}


def relation_call(obj: str, relation: str, reference: str) -> PredicateCall:
    """The predicate that checks a placement relation on a trace."""
    if relation == "out_of_reach":
        return PredicateCall(name="out_of_reach", args=[obj, "robot"], params={"reach": 0.9})
    params = {"distance": 0.45} if relation == "near" else {}
    return PredicateCall(name=_PRED[relation], args=[obj, reference], params=params)


def _scenario(path, behavior: BehaviorDef, fname: str, item_name, item_asset, item_size, geometry,
              requests: list[Request], result: PlacementResult, narrative: str,
              relaxations: list[str], fallbacks: list[str], seed: int,
              powers: dict[str, str] | None = None) -> Scenario:
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
    if item_name:
        assert behavior.item is not None and item_size is not None
        box, ix, iy, iz = _item_box(behavior, item_size)
        entities.append(Entity(name=item_name, asset=item_asset, kind="object",
                               properties={"role": "item"}, behavior="stationary"))
        params[item_name] = {"x": ix, "y": iy, "z": iz, "length": item_size[0],
                             "width": item_size[1], "height": item_size[2], "dynamic": True}
    for r in requests:
        power = (powers or {}).get(r.asset)
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
    fsm = build_fsm(behavior, fname, item_name, requests)
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


def _articulation(behavior: BehaviorDef) -> str:
    if behavior.start_fraction <= 0.05:
        return "closed"
    return "open" if behavior.start_fraction >= 0.75 else "half_open"


def build_fsm(behavior: BehaviorDef, fname: str, item: str | None, requests: list[Request]) -> FSM:
    """Stages: context in place and furniture in its initial state; the hand at the handle or
    item; the behavior's success predicates with the context still in place."""
    states: list[AbstractState] = []
    first: list[StateRef] = []
    last: list[StateRef] = []
    for r in requests:
        # the context is the cause: it holds before the robot acts (stage 1) and still at the end
        states.append(AbstractState(name="placed", actor=r.name, cause=True,
                                    all_of=[relation_call(r.name, r.relation, r.reference)]))
        first.append(StateRef(actor=r.name, state="placed"))
        last.append(StateRef(actor=r.name, state="placed"))
    spec = furniture(behavior.furniture)
    if spec.joint is not None:
        if behavior.start_fraction <= 0.05:
            call = PredicateCall(name="joint_closed", args=[fname], params={"at_most": 0.1})
        else:
            call = PredicateCall(name="joint_open", args=[fname],
                                 params={"at_least": round(behavior.start_fraction - 0.1, 3)})
        states.append(AbstractState(name="initial", actor=fname, all_of=[call]))
        first.append(StateRef(actor=fname, state="initial"))
    reach_target = item if behavior.script == "pick_place" and item else fname
    states.append(AbstractState(name="reaching", actor="robot", all_of=[
        PredicateCall(name="ee_near", args=["robot", reach_target], params={"distance": 0.08})]))
    subst = {"F": fname, "I": item or fname, "robot": "robot"}
    done = [c.model_copy(update={"args": [subst[a] for a in c.args]}) for c in behavior.success]
    states.append(AbstractState(name="task_done", actor="robot", all_of=done))
    last.insert(0, StateRef(actor="robot", state="task_done"))
    stages = []
    if first:
        stages.append(Stage(conditions=first))
    stages.append(Stage(conditions=[StateRef(actor="robot", state="reaching")]))
    stages.append(Stage(conditions=last))
    return FSM(states=states, stages=stages)
