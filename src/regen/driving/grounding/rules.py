"""Grounding: a cause path becomes a driving Scenario (entities, FSM, solved parameters).

Two grounders share everything after the choice of roles: the rule-based one (deterministic,
model-free: per-asset defaults) and the model one (:mod:`regen.driving.grounding.model`), whose
validated answer gives the narrative, the roles and the FSM. Which one was used is recorded in
``scenario.world``.

The causal graph is the specification: what it chose for an entity (behavior, start location,
speed class, property values) is binding on both; they only fill what it left open. A choice
grounding cannot honor raises :class:`~regen.errors.UngroundableError` naming the entity, the
property and the value; it is never swapped for another.
"""

from __future__ import annotations

import hashlib
import math

from regen.assets.database import AssetDatabase
from regen.core.graph import CausePath
from regen.core.scenario import FSM, Entity, Scenario
from regen.driving.assets import database as driving_database
from regen.driving.grounding.fsm_rules import CAUSES_ADDED, rule_based_fsm, with_cause_states
from regen.driving.grounding.placement import refit_speeds, solve
from regen.driving.primitives import find, for_actor, get, is_state_only
from regen.driving.primitives.base import SPEED_CLASSES, Placed
from regen.driving.world.actors import PARKED_ASSETS, PEDESTRIAN_ASSETS, ActorSpec, RoleChoice
from regen.driving.world.egos import EGO_SIZE, EgoTemplate, on_junction_map
from regen.driving.world.imported import imported_entities, with_imported
from regen.driving.world.locations import LOCATIONS, Location, location_from_text
from regen.driving.world.maps import geometry
from regen.driving.world.plan import ActorPlan
from regen.driving.world.properties import state_schedules
from regen.driving.world.replay import ego_template
from regen.driving.world.sensing import sensing_spec
from regen.driving.world.setting import DrivingParams, DrivingWorld, ImportedActor
from regen.driving.world.triggers import Trigger
from regen.errors import ConfigError, GroundingError, UngroundableError

DT = 0.1  # simulation step [s]


def _default_primitive(db: AssetDatabase, asset: str) -> str:
    behaviors = db.assets[asset].behaviors
    if asset in PEDESTRIAN_ASSETS and "cross_the_road" in behaviors:
        return "cross_the_road"
    if "drive_forward" in behaviors:
        return "drive_forward"
    return "stationary" if "stationary" in behaviors else ""


def default_location(primitive: str, asset: str) -> str:
    """A sensible start location when none is given: pedestrians and parked cars at the road
    side, else the first its primitive supports (lights and sensors: their own)."""
    if asset in PEDESTRIAN_ASSETS or asset in PARKED_ASSETS:
        return "roadside_ahead"
    try:
        starts = for_actor(asset, primitive).starts
    except GroundingError:  # an unknown primitive: check_roles reports it
        starts = ()
    return starts[0] if starts else "ahead_same_lane"  # (a sensor has no place of its own)


def ungroundable(name: str, prop: str, value: str, why: str) -> UngroundableError:
    """The error for a choice of the graph that grounding cannot honor: it names the entity,
    the property, the value and why."""
    return UngroundableError(f"{name}: the graph's {prop} = {value!r} cannot be honored: {why}")


def _one(values: list[str], what: str, entity: str) -> str | None:
    uniq = list(dict.fromkeys(values))
    if len(uniq) > 1:
        raise GroundingError(f"contradictory properties: {entity} has {what} = {' and '.join(uniq)} "
                             "at once; keep one value")
    return uniq[0] if uniq else None


def _template(path: CausePath) -> EgoTemplate:
    try:
        return ego_template(path.behavior.text, DrivingParams.of(path.behavior))
    except ConfigError as exc:
        raise GroundingError(str(exc)) from None


def _host_problem(template: EgoTemplate, role: RoleChoice) -> str | None:
    """Why no map of ``template`` can host ``role`` alone, or None."""
    try:
        choose_map(template, [role])
    except GroundingError as exc:
        return str(exc)
    return None


def entity_host_problem(path: CausePath, index: int, db: AssetDatabase | None = None) -> str | None:
    """Why no map of the path's ego behavior can host its entity ``index`` alone, placed as the
    rules place it, or None (other problems with the entity are grounding's to report)."""
    db, pe = db or driving_database(), path.entities[index]
    try:
        template = _template(path)
        props = {k: v[0] for k, v in pe.properties.items() if v}
        role = _graph_role(f"{pe.asset}1", pe.asset, props, db, template) if pe.asset in db.assets else None
    except GroundingError:
        return None
    return None if role is None else _host_problem(template, role)


def _preferred(first: str, options: tuple[str, ...] | list[str]) -> list[str]:
    return ([first] if first in options else []) + [o for o in options if o != first]


def _motion(name: str, asset: str, prim: str | None, loc: str | None, loc_shown: str, moving: bool,
            db: AssetDatabase, template: EgoTemplate) -> tuple[str, str]:
    """(primitive, start location) of an asset with motion primitives: the graph's where it
    chose them, else the first defaults that suit its choices (``moving``: it gave a speed) and
    that the ego's map can host."""
    behaviors = db.assets[asset].behaviors
    if prim is not None and prim not in behaviors:
        raise ungroundable(name, "behavior", prim, f"a {asset} supports only {', '.join(behaviors)}")
    prims = [prim] if prim is not None else _preferred(_default_primitive(db, asset), behaviors)
    pairs = [(p, x) for p in prims
             for x in ([loc] if loc is not None else _preferred(default_location(p, asset), get(p).starts))
             if x in get(p).starts]
    if moving:  # the graph gave it a speed: a primitive that moves (else the speed check says why)
        pairs = [(p, x) for p, x in pairs if get(p).moves] or pairs
    if not pairs:
        if prim is not None:
            raise ungroundable(name, "start_location", loc_shown, f"{prim} (its behavior in the graph) "
                               f"starts only at {', '.join(get(prim).starts)}")
        raise ungroundable(name, "start_location", loc_shown, f"no behavior of a {asset} starts there "
                           f"({', '.join(behaviors)})")
    why = ""
    for p, x in pairs:
        problem = _host_problem(template, RoleChoice(name=name, asset=asset, primitive=p, location=x,
                                                     speed_class="moderate"))
        if problem is None:
            return p, x
        why = why or problem
    if loc is not None:
        raise ungroundable(name, "start_location", loc_shown, why)
    if prim is not None:
        raise ungroundable(name, "behavior", prim, why)
    raise GroundingError(f"{name}: none of the behaviors and start locations of a {asset} fits the ego "
                         f"template {template.id!r} ({why})")


def _switching(name: str, asset: str, prim: str | None, loc: str | None, loc_shown: str) -> str:
    """The start location of a light or sensor (it has no motion primitive)."""
    spec = for_actor(asset, "")
    if prim is not None and prim != "stationary":
        raise ungroundable(name, "behavior", prim, f"a {asset} does not move, it only switches state")
    if loc is not None and loc not in spec.starts:
        where = f"it stands at {', '.join(spec.starts)}" if spec.starts else "it rides on the ego"
        raise ungroundable(name, "start_location", loc_shown, f"a {asset} has no such place: {where}")
    return loc or default_location("", asset)


def _property_problems(r: RoleChoice, db: AssetDatabase) -> list[str]:
    """The property values of ``r`` (the graph's) that its asset cannot show."""
    problems = []
    spec = db.assets[r.asset]
    for key, val in r.properties.items():
        if key not in spec.properties:
            problems.append(f"{r.name}: the graph's {key} = {val!r} cannot be honored: a {r.asset} has "
                            f"no property {key!r}")
            continue
        states = db.properties[key].states
        if states is not None and val not in states:
            problems.append(f"{r.name}: the graph's {key} = {val!r} cannot be honored: {key} is one of "
                            f"{', '.join(states)}")
    spec_p = find(r.primitive) if r.primitive else None
    for key, val in (spec_p.implies.items() if spec_p else ()):
        if key in r.properties and r.properties[key] != val:
            problems.append(f"{r.name}: the graph's {key} = {r.properties[key]!r} cannot be honored: "
                            f"{r.primitive} means {key} = {val}")
    return problems


def implied(primitive: str, asset: str, props: dict[str, str], db: AssetDatabase) -> dict[str, str]:
    """``props`` with the states ``primitive`` implies (siren on) where the graph names none."""
    spec = find(primitive) if primitive else None
    extra = {k: v for k, v in (spec.implies.items() if spec else ()) if k in db.parameters_of(asset)}
    return {**extra, **props}


def _graph_role(name: str, asset: str, props: dict[str, str], db: AssetDatabase,
                template: EgoTemplate) -> RoleChoice:
    prim = props.pop("behavior", None)
    loc_text = props.pop("start_location", None)
    props.pop("end_location", None)  # no primitive takes one: where it ends follows from its motion
    speed = props.pop("target_speed", None)
    loc = None
    shown = ""
    if loc_text is not None:
        loc = location_from_text(loc_text)
        if loc is None:
            raise ungroundable(name, "start_location", loc_text, "it names none of the start locations "
                               f"grounding can place ({', '.join(LOCATIONS)})")
        shown = loc_text if loc == loc_text else f"{loc_text} ({loc})"  # as the graph wrote it
    state_only = is_state_only(asset)
    if state_only:
        location = _switching(name, asset, prim, loc, shown)
        primitive = ""
        prim = None if prim == "stationary" else prim  # (implied: it does not move)
    else:
        primitive, location = _motion(name, asset, prim, loc, shown, speed is not None, db, template)
    if speed is not None:
        if speed not in SPEED_CLASSES:
            raise ungroundable(name, "target_speed", speed, f"the speed classes are {', '.join(SPEED_CLASSES)}")
        if state_only or not get(primitive).moves:
            raise ungroundable(name, "target_speed", speed, f"a {asset} that is {primitive or 'a light or sensor'} "
                               "does not move")
    fixed = frozenset(k for k, v in (("behavior", prim), ("start_location", loc), ("target_speed", speed))
                      if v is not None)
    role = RoleChoice(name=name, asset=asset, primitive=primitive, location=location,
                      speed_class=speed or "moderate", properties=implied(primitive, asset, props, db), fixed=fixed)
    problems = _property_problems(role, db)
    if problems:
        raise UngroundableError("; ".join(problems))
    return role


def rule_based_roles(path: CausePath, db: AssetDatabase | None = None) -> list[RoleChoice]:
    """Roles from the path: what the graph chose for an entity (behavior, start location, speed
    class, property values) is binding; what it left open gets per-asset defaults that its
    choices allow and the ego's map can host.

    Raises :class:`UngroundableError` (entity, property and value named) for a choice no rule
    can honor, :class:`GroundingError` for unknown assets and contradictory values.
    """
    db = db or driving_database()
    template = _template(path)
    roles: list[RoleChoice] = []
    counts: dict[str, int] = {}
    for pe in path.entities:
        if pe.asset not in db.assets:
            raise GroundingError(f"the asset {pe.asset!r} is not in the driving database")
        counts[pe.asset] = counts.get(pe.asset, 0) + 1
        name = f"{pe.asset}{counts[pe.asset]}"
        props: dict[str, str] = {}
        for key, vals in pe.properties.items():
            v = _one(vals, key, name)
            if v is not None:
                props[key] = v
        roles.append(_graph_role(name, pe.asset, props, db, template))
    choose_map(template, roles)  # together (UngroundableError when it is the graph's choices)
    return roles


def graph_problems(path: CausePath, roles: list[RoleChoice]) -> list[str]:
    """Where ``roles`` differ from what the path's graph chose (empty: they honor it)."""
    if [r.asset for r in roles] != [pe.asset for pe in path.entities]:
        return [f"the roles ({', '.join(r.name for r in roles)}) are not the path's entities "
                f"({', '.join(pe.asset for pe in path.entities)})"]
    out = []
    for pe, r in zip(path.entities, roles, strict=True):
        for key, vals in pe.properties.items():
            if not vals or key == "end_location":
                continue
            want = vals[0]
            if key == "behavior":
                if is_state_only(r.asset) and want == "stationary":
                    continue
                have = r.primitive
            elif key == "start_location":
                want, have = location_from_text(want) or want, r.location
            elif key == "target_speed":
                have = r.speed_class
            else:
                have = r.properties.get(key, "")
            if have != want:
                out.append(f"{r.name}: the graph's {key} = {want!r} became {have!r}")
    return out


def check_roles(roles: list[RoleChoice], db: AssetDatabase) -> list[str]:
    """Problems with roles that no map can fix: unsupported behaviors, bad property values."""
    problems: list[str] = []
    for r in roles:
        spec = db.assets.get(r.asset)
        if spec is None:
            problems.append(f"{r.name}: unknown asset {r.asset!r}")
            continue
        if not is_state_only(r.asset):
            if r.primitive not in spec.behaviors:
                problems.append(f"{r.name}: a {r.asset} cannot {r.primitive!r}; it supports "
                                f"{', '.join(spec.behaviors)}")
            elif r.location not in get(r.primitive).starts:
                problems.append(f"{r.name}: {r.primitive} cannot start at {r.location!r}; allowed: "
                                f"{', '.join(get(r.primitive).starts)}")
        problems += _property_problems(r, db)
    return problems


def _where(r: RoleChoice) -> Location:
    loc = LOCATIONS.get(r.location)
    if loc is None:
        raise GroundingError(f"{r.name}: unknown start location {r.location!r}; use one of "
                             f"{', '.join(LOCATIONS)}")
    return loc


def _cannot_host(roles: list[RoleChoice], why: str) -> GroundingError:
    """No map hosts ``roles``: UngroundableError when their place or primitive is the graph's."""
    text = f"the map cannot host {', '.join(r.name for r in roles)}: {why}"
    chosen = [f"{r.name}: the graph's {k} = {v!r}" for r in roles
              for k, v in r.graph_choices().items() if k != "target_speed"]
    if chosen:
        return UngroundableError(f"{text}; so it cannot honor {', '.join(chosen)}")
    return GroundingError(text)


def can_host(template: EgoTemplate, location: str, *, junction_primitive: bool = False) -> bool:
    """Whether some map of ``template`` can host an actor starting at ``location`` (a primitive
    that needs a junction: ``junction_primitive``): the rules of :func:`choose_map` for one
    role, so the graph is offered only the places the ego's behavior can meet."""
    loc = LOCATIONS.get(location)
    if loc is None:
        return False
    t = template
    if loc.needs_junction or junction_primitive:
        if not geometry(t.map).junction:
            if "four_way" not in t.junction_maps:
                return False
            t = on_junction_map(t, "four_way")
        if t.passes_junction:
            return False
    if loc.needs_second_lane and t.frame.lanes_same_direction < 2:
        return False
    return not (loc.behind_ego and t.starts_elsewhere)


def choose_map(template: EgoTemplate, roles: list[RoleChoice]) -> EgoTemplate:
    """The template placed on a map that can host every role (GroundingError if none can;
    UngroundableError if what the map cannot host is a place or primitive the graph chose)."""
    needs_junction = [r for r in roles if _where(r).needs_junction
                      or for_actor(r.asset, r.primitive).needs_junction]
    needs_lanes = [r for r in roles if _where(r).needs_second_lane]
    t = template
    if needs_junction and not geometry(t.map).junction:
        options = [m for m in t.junction_maps if m == "four_way"]
        if not options:
            raise _cannot_host(needs_junction, f"ego template {t.id!r} runs on a road without a junction")
        t = on_junction_map(t, options[0])
    if t.passes_junction and needs_junction:
        raise _cannot_host(needs_junction, t.passes_junction)
    if needs_lanes and t.frame.lanes_same_direction < 2:
        raise _cannot_host(needs_lanes, f"the ego's road ({t.map}) has no second lane in its direction")
    if t.starts_elsewhere:
        behind = [r for r in roles if _where(r).behind_ego]
        if behind:
            raise _cannot_host(behind, t.starts_elsewhere)
    return t


def _size(db: AssetDatabase, asset: str) -> tuple[float, float, float]:
    s = db.assets[asset].size
    return (float(s[0]), float(s[1]), float(s[2]))


def actor_spec(r: RoleChoice, db: AssetDatabase) -> ActorSpec:
    return ActorSpec(name=r.name, asset=r.asset, primitive=r.primitive, location=r.location,
                     speed_class=r.speed_class, properties=dict(r.properties), size=_size(db, r.asset))


def scenario_id(path: CausePath, seed: int) -> str:
    return f"{path.key}-{hashlib.sha1(str(seed).encode()).hexdigest()[:4]}"


def build_scenario(path: CausePath, roles: list[RoleChoice], *, narrative: str, fsm: FSM | None,
                   grounder: str, seed: int = 0, db: AssetDatabase | None = None) -> Scenario:
    """Check roles, pick the map, solve the parameters and assemble the Scenario (with the
    rule-based FSM when ``fsm`` is None).

    Raises :class:`UngroundableError` for roles that differ from what the path's graph chose or
    that no map can host where the graph chose their place, :class:`GroundingError` for other
    roles no map can host; an infeasible placement is a Scenario with
    ``solver.status == 'infeasible'`` and the conflicts named.
    """
    db = db or driving_database()
    template = _template(path)
    problems = graph_problems(path, roles)
    if problems:  # a guard: both grounders honor the graph by construction
        raise UngroundableError("; ".join(problems))
    problems = check_roles(roles, db)
    if problems:
        raise GroundingError("; ".join(problems))
    template = choose_map(template, roles)
    sol = solve(template, [actor_spec(r, db) for r in roles], seed=seed)
    if sol.report.status == "infeasible" and template.map != "four_way" and "four_way" in template.junction_maps:
        # the T-junction has no north arm: a car that must come through the junction needs one
        wider = on_junction_map(template, "four_way")
        again = solve(wider, [actor_spec(r, db) for r in roles], seed=seed)
        if again.report.status != "infeasible":
            template, sol = wider, again
    refit: list[str] = []
    if sol.report.status == "infeasible":
        roles, sol, refit = refit_speeds(template, roles, sol, lambda r: actor_spec(r, db), seed=seed)
    entities = [Entity(name="ego", asset="ego", kind="robot", behavior=template.id,
                       behavior_params={"text": path.behavior.text})]
    for r in roles:
        kind = db.assets[r.asset].kind
        entities.append(Entity(name=r.name, asset=r.asset, kind="object" if kind == "sensor" else kind,
                               properties=dict(r.properties),
                               behavior=None if is_state_only(r.asset) else r.primitive,
                               behavior_params={"location": r.location, "speed_class": r.speed_class}))
    added: list[str] = []
    if fsm is None:
        fsm = rule_based_fsm(roles, template)
    else:  # an FSM written elsewhere still shows every cause before the ego's reaction
        fsm, added = with_cause_states(fsm, roles, template)
    board = DrivingParams.of(path.behavior).imported
    if board is not None:  # the actors of an imported file stay with what is added around them
        entities += imported_entities(board)
        fsm = with_imported(fsm, board, {n for n, _ in template.ego_states()[1]})
    world = DrivingWorld(map=template.map, ego_template=template.id, duration=template.duration, dt=DT,
                         seed=seed, grounder=grounder).as_world()
    params = {k: dict(v) for k, v in sol.params.items()}
    return Scenario(id=scenario_id(path, seed), domain="driving", behavior=path.behavior,
                    causal_graph=list(path.events), narrative=narrative, entities=entities,
                    fsm=fsm, parameters=params, world=world, solver=sol.report,
                    fallbacks=([CAUSES_ADDED + "; ".join(added)] if added else []) + refit)


def default_narrative(path: CausePath) -> str:
    return " ".join(path.events[:-1]) + f", so {path.events[-1][0].lower()}{path.events[-1][1:]}."


def ground_rule_based(path: CausePath, *, seed: int = 0, db: AssetDatabase | None = None) -> Scenario:
    """The deterministic, model-free grounder: the graph's choices, defaults for the rest."""
    db = db or driving_database()
    roles = rule_based_roles(path, db)
    return build_scenario(path, roles, narrative=default_narrative(path), fsm=None,
                          grounder="rule-based", seed=seed, db=db)


def roles_of(scenario: Scenario) -> list[RoleChoice]:
    out = []
    for e in scenario.entities:
        if e.name == "ego":
            continue
        out.append(RoleChoice(name=e.name, asset=e.asset, primitive=e.behavior or "stationary",
                              location=str(e.behavior_params.get("location", "")),
                              speed_class=str(e.behavior_params.get("speed_class", "moderate")),
                              properties=dict(e.properties)))
    return out


def template_of(scenario: Scenario) -> EgoTemplate:
    w = DrivingWorld.of(scenario)
    params = DrivingParams.of(scenario.behavior)
    if params.recorded is not None:  # the recording's own map and route
        return ego_template(scenario.behavior.text, params)
    t = ego_template(scenario.behavior.text, params.model_copy(update={"ego_template": w.ego_template}))
    m = w.map or t.map
    return on_junction_map(t, m) if m != t.map else t


def imported_plan(a: ImportedActor, r: RoleChoice, db: AssetDatabase) -> ActorPlan:
    """The plan of an imported actor: its poses replayed, its cause event after its trigger."""
    spec = db.assets[r.asset]
    x, y, h, v = a.before[0]
    cls = "Pedestrian" if db.category_of(r.asset) == "pedestrians" else (
        "Car" if db.category_of(r.asset) == "vehicles" else "Object")
    moving = max(p[3] for p in a.before + a.after) > 0.0
    return ActorPlan(name=a.name, asset=r.asset, kind=spec.kind, cls=cls, x=x, y=y, heading=h,
                     length=spec.size[0], width=spec.size[1], height=spec.size[2], speed0=v,
                     scenic_behavior="ReplayPath" if moving else "", replay=list(a.before) if moving else [],
                     trigger=Trigger.of(a.trigger) if a.trigger is not None and (a.after or a.states) else None,
                     after=list(a.after), after_relative=a.relative,
                     states={**{k: [(0.0, v)] for k, v in r.properties.items()}, **a.states},
                     comment=f"imported from {a.source}: {a.action} when {a.condition}" if a.event else "imported")


def plans_for(scenario: Scenario, db: AssetDatabase | None = None) -> tuple[EgoTemplate, list[ActorPlan]]:
    """Deterministic executable plans of a grounded scenario (the ego first)."""
    db = db or driving_database()
    t = template_of(scenario)
    ex, ey = t.route[0]
    nx, ny = t.route[1]
    ego = ActorPlan(name="ego", asset="ego", kind="ego", cls="Car", x=ex, y=ey,
                    heading=math.atan2(ny - ey, nx - ex), length=EGO_SIZE[0], width=EGO_SIZE[1],
                    height=EGO_SIZE[2], speed0=t.speed0, route=list(t.route),
                    schedule=list(t.schedule), comment=t.description,
                    scenic_behavior="ReplayPath" if t.replay else "FollowRoute", replay=list(t.replay))
    plans = [ego]
    board = DrivingParams.of(scenario.behavior).imported
    imported = {a.name: a for a in board.actors} if board is not None else {}
    for r in roles_of(scenario):
        if r.name in imported:  # an actor of an imported OpenSCENARIO file: its story replayed
            plans.append(imported_plan(imported[r.name], r, db))
            continue
        params = dict(scenario.parameters.get(r.name, {}))
        placed = Placed(actor=actor_spec(r, db), kind=db.assets[r.asset].kind, params=params, ego=t)
        plan = for_actor(r.asset, r.primitive).plan(placed)
        plan.states = state_schedules(r, params, t)
        plans.append(plan)
    ego.sensing = sensing_spec(plans, t)  # an ego that reacts to what a degraded sensor makes it perceive
    return t, plans
