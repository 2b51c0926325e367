"""Grounding: a cause path becomes a driving Scenario (entities, FSM, solved parameters).

Two grounders share everything after the choice of roles: the rule-based one (deterministic,
model-free: behavior and start location come from the path's properties or per-asset
defaults) and the model one (:mod:`regen.driving.llm_ground`), whose validated answer gives
the narrative, the roles and the FSM. Which one was used is recorded in ``scenario.world``.
"""

from __future__ import annotations

import hashlib
import logging
import math

from regen.assets.database import AssetDatabase
from regen.core.graph import CausePath
from regen.core.scenario import FSM, Entity, Scenario
from regen.driving.actors import PARKED_ASSETS, PEDESTRIAN_ASSETS, ActorSpec, RoleChoice
from regen.driving.assets import database as driving_database
from regen.driving.ego import EGO_SIZE, EgoTemplate, on_junction_map, template_for
from regen.driving.fsm_rules import rule_based_fsm
from regen.driving.locations import LOCATIONS, Location, location_from_text
from regen.driving.maps import geometry
from regen.driving.plan import ActorPlan
from regen.driving.primitives import for_actor, get, is_state_only
from regen.driving.primitives.base import Placed
from regen.driving.properties import state_schedules
from regen.driving.solve import solve
from regen.errors import ConfigError, GroundingError

log = logging.getLogger(__name__)

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


def _one(values: list[str], what: str, entity: str) -> str | None:
    uniq = list(dict.fromkeys(values))
    if len(uniq) > 1:
        raise GroundingError(f"contradictory properties: {entity} has {what} = {' and '.join(uniq)} "
                             "at once; keep one value")
    return uniq[0] if uniq else None


def rule_based_roles(path: CausePath, db: AssetDatabase, notes: list[str] | None = None) -> list[RoleChoice]:
    """Roles from the path's entities and properties, with per-asset defaults.

    Strict by default: a start location no rule can place is a GroundingError. With a ``notes``
    list, unplaceable locations and unsupported behaviors get the defaults instead and a note
    (model grounding starts from these). Unknown assets and contradictory values always raise:
    nothing can fix the path itself.
    """
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
        prim = props.pop("behavior", None)
        if notes is not None and prim is not None and prim not in db.assets[pe.asset].behaviors:
            notes.append(f"{name}: a {pe.asset} cannot {prim!r}")
            prim = None
        prim = prim or _default_primitive(db, pe.asset)
        loc_text = props.pop("start_location", None)
        props.pop("end_location", None)
        loc = location_from_text(loc_text) if loc_text else None
        if loc_text and loc is None:
            if notes is None:
                raise GroundingError(f"{name}: cannot place start location {loc_text!r}; use one of "
                                     f"{', '.join(LOCATIONS)}")
            notes.append(f"{name}: cannot place start location {loc_text!r}")
        speed = props.pop("target_speed", "moderate")
        roles.append(RoleChoice(name=name, asset=pe.asset, primitive=prim,
                                location=loc or default_location(prim, pe.asset),
                                speed_class=speed, properties=props))
    return roles


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
        for key, val in r.properties.items():
            if key not in spec.properties:
                problems.append(f"{r.name}: a {r.asset} has no property {key!r}")
                continue
            states = db.properties[key].states
            if states is not None and val not in states:
                problems.append(f"{r.name}: {key} cannot be {val!r}; allowed: {', '.join(states)}")
    return problems


def _where(r: RoleChoice) -> Location:
    loc = LOCATIONS.get(r.location)
    if loc is None:
        raise GroundingError(f"{r.name}: unknown start location {r.location!r}; use one of "
                             f"{', '.join(LOCATIONS)}")
    return loc


def choose_map(template: EgoTemplate, roles: list[RoleChoice]) -> EgoTemplate:
    """The template placed on a map that can host every role (GroundingError if none can)."""
    needs_junction = [r.name for r in roles if _where(r).needs_junction
                      or for_actor(r.asset, r.primitive).needs_junction]
    needs_lanes = [r.name for r in roles if _where(r).needs_second_lane]
    t = template
    if needs_junction and not geometry(t.map).junction:
        options = [m for m in t.junction_maps if m == "four_way"]
        if not options:
            raise GroundingError(f"the map cannot host {', '.join(needs_junction)}: ego template "
                                 f"{t.id!r} runs on a road without a junction")
        t = on_junction_map(t, options[0])
    if t.id == "stop_after_turn" and needs_junction:
        raise GroundingError(f"the map cannot host {', '.join(needs_junction)}: after its turn the "
                             "ego is past the junction")
    if needs_lanes and t.frame.lanes_same_direction < 2:
        raise GroundingError(f"the map cannot host {', '.join(needs_lanes)}: the ego's road "
                             f"({t.map}) has no second lane in its direction")
    if t.id == "stop_after_turn":
        behind = [r.name for r in roles if _where(r).behind_ego]
        if behind:
            raise GroundingError(f"the map cannot host {', '.join(behind)} behind the ego: it "
                                 "starts on another road before its turn")
    return t


def _size(db: AssetDatabase, asset: str) -> tuple[float, float, float]:
    s = db.assets[asset].size
    return (float(s[0]), float(s[1]), float(s[2]))


def _actor(r: RoleChoice, db: AssetDatabase) -> ActorSpec:
    return ActorSpec(name=r.name, asset=r.asset, primitive=r.primitive, location=r.location,
                     speed_class=r.speed_class, properties=dict(r.properties), size=_size(db, r.asset))


def scenario_id(path: CausePath, seed: int) -> str:
    return f"{path.key}-{hashlib.sha1(str(seed).encode()).hexdigest()[:4]}"


def build_scenario(path: CausePath, roles: list[RoleChoice], *, narrative: str, fsm: FSM | None,
                   grounder: str, seed: int = 0, db: AssetDatabase | None = None) -> Scenario:
    """Check roles, pick the map, solve the parameters and assemble the Scenario.

    Raises :class:`GroundingError` for roles no map can host; an infeasible placement is a
    Scenario with ``solver.status == 'infeasible'`` and the conflicts named.
    """
    db = db or driving_database()
    try:
        template = template_for(path.behavior.text, path.behavior.ego_template)
    except ConfigError as exc:
        raise GroundingError(str(exc)) from None
    problems = check_roles(roles, db)
    if problems:
        raise GroundingError("; ".join(problems))
    template = choose_map(template, roles)
    sol = solve(template, [_actor(r, db) for r in roles], seed=seed)
    entities = [Entity(name="ego", asset="ego", kind="ego", behavior=template.id,
                       behavior_params={"text": path.behavior.text})]
    for r in roles:
        kind = db.assets[r.asset].kind
        entities.append(Entity(name=r.name, asset=r.asset, kind="object" if kind == "sensor" else kind,
                               properties=dict(r.properties),
                               behavior=None if is_state_only(r.asset) else r.primitive,
                               behavior_params={"location": r.location, "speed_class": r.speed_class}))
    if fsm is None:
        fsm = rule_based_fsm(roles, template)
    world = {"map": template.map, "ego_template": template.id, "duration": template.duration,
             "dt": DT, "seed": seed, "grounder": grounder}
    params = {k: dict(v) for k, v in sol.params.items()}
    return Scenario(id=scenario_id(path, seed), domain="driving", behavior=path.behavior,
                    causal_graph=list(path.events), narrative=narrative, entities=entities,
                    fsm=fsm, parameters=params, world=world, solver=sol.report)


def default_narrative(path: CausePath) -> str:
    return " ".join(path.events[:-1]) + f", so {path.events[-1][0].lower()}{path.events[-1][1:]}."


def ground_rule_based(path: CausePath, *, seed: int = 0, db: AssetDatabase | None = None) -> Scenario:
    """The deterministic, model-free grounder."""
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
    t = template_for(scenario.behavior.text, str(scenario.world.get("ego_template")))
    m = str(scenario.world.get("map", t.map))
    return on_junction_map(t, m) if m != t.map else t


def plans_for(scenario: Scenario, db: AssetDatabase | None = None) -> tuple[EgoTemplate, list[ActorPlan]]:
    """Deterministic executable plans of a grounded scenario (the ego first)."""
    db = db or driving_database()
    t = template_of(scenario)
    ex, ey = t.route[0]
    nx, ny = t.route[1]
    ego = ActorPlan(name="ego", asset="ego", kind="ego", cls="Car", x=ex, y=ey,
                    heading=math.atan2(ny - ey, nx - ex), length=EGO_SIZE[0], width=EGO_SIZE[1],
                    height=EGO_SIZE[2], speed0=t.speed0, route=list(t.route),
                    schedule=list(t.schedule), comment=t.description, scenic_behavior="FollowRoute")
    plans = [ego]
    for r in roles_of(scenario):
        params = dict(scenario.parameters.get(r.name, {}))
        placed = Placed(actor=_actor(r, db), kind=db.assets[r.asset].kind, params=params, ego=t)
        plan = for_actor(r.asset, r.primitive).plan(placed)
        plan.states = state_schedules(r, params, t)
        plans.append(plan)
    return t, plans
