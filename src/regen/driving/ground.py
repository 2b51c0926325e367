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
import re

from regen.assets.database import AssetDatabase, load_database
from regen.core.graph import CausePath
from regen.core.scenario import FSM, Entity, Scenario
from regen.driving.ego import EGO_SIZE, EgoTemplate, on_junction_map, template_for
from regen.driving.fsm_rules import RoleChoice, rule_based_fsm
from regen.driving.maps import geometry
from regen.driving.plan import ActorPlan
from regen.driving.primitives import (
    ADJACENT_LOCATIONS,
    BEHIND_LOCATIONS,
    JUNCTION_LOCATIONS,
    LOCATIONS,
    PEDESTRIAN_ASSETS,
    PRIMITIVE_LOCATIONS,
    REACTION_TIME,
    build_plan,
    default_location,
    roadside_d,
)
from regen.driving.solve import STATE_ONLY, ActorSpec, lane_offset, solve
from regen.errors import ConfigError, GroundingError

log = logging.getLogger(__name__)

DT = 0.1  # simulation step [s]

# Keywords that map free-text start locations (as the graph's property nodes hold them) to the
# fixed location list; tried in order, all words of an entry must appear.
_LOCATION_WORDS: list[tuple[tuple[str, ...], str]] = [
    (("cross", "street"), "junction_cross_street"),
    (("junction", "opposite"), "junction_oncoming"),
    (("corner",), "junction_corner"),
    (("crosswalk",), "crosswalk_ahead"),
    (("oncoming",), "oncoming_lane"),
    (("opposite", "side"), "roadside_opposite_ahead"),
    (("roadside",), "roadside_ahead"),
    (("sidewalk",), "roadside_ahead"),
    (("curb",), "roadside_ahead"),
    (("behind", "adjacent"), "behind_adjacent_lane"),
    (("behind", "next"), "behind_adjacent_lane"),
    (("behind", "other"), "behind_adjacent_lane"),
    (("behind",), "behind_same_lane"),
    (("front", "adjacent"), "ahead_adjacent_lane"),
    (("ahead", "adjacent"), "ahead_adjacent_lane"),
    (("front",), "ahead_same_lane"),
    (("ahead",), "ahead_same_lane"),
]


def location_from_text(text: str) -> str | None:
    """A start location from free text (exact ids pass through); None when nothing matches."""
    t = text.strip().lower()
    if t in LOCATIONS:
        return t
    words = set(re.findall(r"[a-z]+", t))
    for keys, loc in _LOCATION_WORDS:
        if all(k in words for k in keys):
            return loc
    return None


def _default_primitive(db: AssetDatabase, asset: str) -> str:
    behaviors = db.assets[asset].behaviors
    if asset in PEDESTRIAN_ASSETS and "cross_the_road" in behaviors:
        return "cross_the_road"
    if "drive_forward" in behaviors:
        return "drive_forward"
    return "stationary" if "stationary" in behaviors else ""


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
        if r.asset not in STATE_ONLY:
            if r.primitive not in spec.behaviors:
                problems.append(f"{r.name}: a {r.asset} cannot {r.primitive!r}; it supports "
                                f"{', '.join(spec.behaviors)}")
            elif r.location not in PRIMITIVE_LOCATIONS.get(r.primitive, ()):
                problems.append(f"{r.name}: {r.primitive} cannot start at {r.location!r}; allowed: "
                                f"{', '.join(PRIMITIVE_LOCATIONS.get(r.primitive, ()))}")
        for key, val in r.properties.items():
            if key not in spec.properties:
                problems.append(f"{r.name}: a {r.asset} has no property {key!r}")
                continue
            states = db.properties[key].states
            if states is not None and val not in states:
                problems.append(f"{r.name}: {key} cannot be {val!r}; allowed: {', '.join(states)}")
    return problems


def choose_map(template: EgoTemplate, roles: list[RoleChoice]) -> EgoTemplate:
    """The template placed on a map that can host every role (GroundingError if none can)."""
    needs_junction = [r.name for r in roles if r.location in JUNCTION_LOCATIONS
                      or r.primitive in ("turn_left", "turn_right", "run_red_light")]
    needs_lanes = [r.name for r in roles if r.location in ADJACENT_LOCATIONS]
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
        behind = [r.name for r in roles if r.location in BEHIND_LOCATIONS]
        if behind:
            raise GroundingError(f"the map cannot host {', '.join(behind)} behind the ego: it "
                                 "starts on another road before its turn")
    return t


def _size(db: AssetDatabase, asset: str) -> tuple[float, float, float]:
    s = db.assets[asset].size
    return (float(s[0]), float(s[1]), float(s[2]))


def _specs(roles: list[RoleChoice], db: AssetDatabase) -> list[ActorSpec]:
    return [ActorSpec(r.name, r.asset, r.primitive, r.location, r.speed_class, _size(db, r.asset),
                      dict(r.properties)) for r in roles]


def scenario_id(path: CausePath, seed: int) -> str:
    return f"{path.key}-{hashlib.sha1(str(seed).encode()).hexdigest()[:4]}"


def build_scenario(path: CausePath, roles: list[RoleChoice], *, narrative: str, fsm: FSM | None,
                   grounder: str, seed: int = 0, db: AssetDatabase | None = None) -> Scenario:
    """Check roles, pick the map, solve the parameters and assemble the Scenario.

    Raises :class:`GroundingError` for roles no map can host; an infeasible placement is a
    Scenario with ``solver.status == 'infeasible'`` and the conflicts named.
    """
    db = db or load_database("driving")
    try:
        template = template_for(path.behavior.text, path.behavior.ego_template)
    except ConfigError as exc:
        raise GroundingError(str(exc)) from None
    problems = check_roles(roles, db)
    if problems:
        raise GroundingError("; ".join(problems))
    template = choose_map(template, roles)
    sol = solve(template, _specs(roles, db), seed=seed)
    entities = [Entity(name="ego", asset="ego", kind="ego", behavior=template.id,
                       behavior_params={"text": path.behavior.text})]
    for r in roles:
        kind = db.assets[r.asset].kind
        entities.append(Entity(name=r.name, asset=r.asset, kind="object" if kind == "sensor" else kind,
                               properties=dict(r.properties),
                               behavior=None if r.asset in STATE_ONLY else r.primitive,
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
    db = db or load_database("driving")
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


def _state_schedules(r: RoleChoice, p: dict[str, float], t: EgoTemplate) -> dict[str, list]:
    out: dict[str, list] = {}
    ts = p.get("t", t.t_event - 1.0)
    for key, val in r.properties.items():
        if key == "door":
            out[key] = [(0.0, "closed"), (ts, "open")] if val == "opens" else [(0.0, val)]
        elif key == "light_state":
            if val == "turns_red":
                out[key] = [(0.0, "green"), (max(0.0, ts - 2.0), "yellow"), (ts, "red")]
            elif val == "red" and t.id == "drive_forward":
                out[key] = [(0.0, "red"), (ts, "green")]
            else:
                out[key] = [(0.0, val)]
        elif key == "gnss_signal" and val != "nominal":
            out[key] = [(0.0, "nominal"), (ts, val)]
        elif key == "camera_view" and val != "clear":
            out[key] = [(0.0, "clear"), (ts, val)]
        elif key in ("behavior", "start_location", "end_location", "target_speed"):
            continue
        else:
            out[key] = [(0.0, val)]
    return out


def plans_for(scenario: Scenario, db: AssetDatabase | None = None) -> tuple[EgoTemplate, list[ActorPlan]]:
    """Deterministic executable plans of a grounded scenario (the ego first)."""
    db = db or load_database("driving")
    t = template_of(scenario)
    ex, ey = t.route[0]
    nx, ny = t.route[1]
    ego = ActorPlan(name="ego", asset="ego", kind="ego", cls="Car", x=ex, y=ey,
                    heading=math.atan2(ny - ey, nx - ex), length=EGO_SIZE[0], width=EGO_SIZE[1],
                    height=EGO_SIZE[2], speed0=t.speed0, route=list(t.route),
                    schedule=list(t.schedule), comment=t.description)
    plans = [ego]
    for r in roles_of(scenario):
        p = dict(scenario.parameters.get(r.name, {}))
        size = _size(db, r.asset)
        kind = db.assets[r.asset].kind
        if kind == "sensor":
            plan = ActorPlan(name=r.name, asset=r.asset, kind="sensor", cls="", x=ex, y=ey,
                             heading=ego.heading, length=0.1, width=0.1, height=0.1,
                             attach_to="ego", comment="sensor on the ego")
        elif r.asset == "traffic_light" and not geometry(t.map).junction:
            s = (t.s_end if t.stops else t.s_event) + 6.0
            x, y = t.frame.point(s, t.frame.sidewalk_d("right"))
            plan = ActorPlan(name=r.name, asset=r.asset, kind="object", cls="Object", x=x, y=y,
                             heading=t.frame.heading + math.pi, length=size[0], width=size[1],
                             height=size[2], comment="traffic light at a crossing")
        else:
            spec = ActorSpec(r.name, r.asset, r.primitive, r.location, r.speed_class, size, r.properties)
            p["lane_d"] = lane_offset(t, spec)
            if r.primitive == "drive_forward" and r.location == "ahead_same_lane" and "t" in p:
                if t.stops:
                    p["brake_t"] = p["t"]
                elif t.speed_event == 0.0:
                    p["start_t"] = p["t"]
            if r.primitive == "drive_forward" and r.location == "behind_same_lane" and t.stops:
                react = REACTION_TIME.get(r.properties.get("driver_state", "attentive"), 1.0)
                p["brake_t"] = t.t_event + react
            plan = build_plan(r.name, r.asset, "object" if kind == "object" else "agent", size,
                              r.primitive, r.location, p, t)
            if r.location in ("roadside_ahead", "roadside_opposite_ahead") and r.primitive == "stationary":
                side = "left" if r.location == "roadside_opposite_ahead" else "right"
                plan.x, plan.y = t.frame.point(p.get("s", 0.0), roadside_d(t, r.asset, size[1], side))
        plan.states = _state_schedules(r, p, t)
        plan.cls = plan.cls if kind != "sensor" else ""
        plans.append(plan)
    return t, plans
