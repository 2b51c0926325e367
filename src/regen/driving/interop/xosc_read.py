"""Read an OpenSCENARIO 1.x file into plain data: entities, their start, their events.

What is read (everything else is named in one :class:`~regen.errors.ConfigError` that lists each
element, attribute and value and where it is, never dropped silently):

- ``RoadNetwork/LogicFile``: the ``.xodr`` map, relative to the file;
- ``ScenarioObject`` with a ``Vehicle`` (category, role), ``Pedestrian`` or ``MiscObject``, its
  bounding box and ``Property`` entries (``regen_asset`` and ``regen_<property>`` as this
  project writes them);
- ``Init``: ``TeleportAction`` to a ``WorldPosition`` and an absolute ``SpeedAction``;
- events of ``Story/Act/ManeuverGroup/Maneuver``: ``FollowTrajectoryAction`` along a
  ``Polyline`` of timed ``WorldPosition`` vertices (absolute or relative timing), ``SpeedAction``
  to an absolute target speed and ``LaneChangeAction`` to a relative target lane (step, linear,
  cubic or sinusoidal dynamics over time, distance or rate);
- ``TrafficSignalStateAction`` (in ``Init`` and in events): a signal of the map, by its id;
  ``UserDefinedAction/CustomCommandAction`` of the types this project writes (``regen:door``,
  ``regen:siren``, ``regen:hazard_lights``; :mod:`regen.driving.interop.appearance`) and, from
  OpenSCENARIO 1.3 files, ``AppearanceAction``: a door's ``AnimationAction``, the
  ``LightStateAction`` of special purpose lights (a siren) and warning lights (hazard lights);
- start conditions (with their delays): ``SimulationTimeCondition``, ``DistanceCondition`` and
  ``TimeToCollisionCondition`` to a ``WorldPosition``, ``SpeedCondition``,
  ``RelativeDistanceCondition`` (longitudinal); condition groups are OR-ed, conditions within a
  group AND-ed;
- ``StopTrigger``: a ``SimulationTimeCondition``.

Read and without effect on a kinematic replay on a generated map (so not named): names, the
file header's date, author and minor revision, catalog locations, an entity's mass, model,
performance, axles, bounding-box centre and controller, a position's z, pitch and roll, the
trajectory following mode, a scene graph file, and the attribute values that mean what the
replay does anyway (``conditionEdge`` none or rising, ``freespace`` false, one execution, ...:
:data:`.xosc_record.SAME`).

Every other element and attribute, every value that is not a finite number where a number
belongs or not one of the values the standard allows, and every parameter reference (``$name``:
parameters are not substituted) is named, with where it is, in one
:class:`~regen.errors.ConfigError`; nothing is dropped silently. The elements record what the
reader reads of them (:mod:`.xosc_record`), and whatever it did not read is what is named.

Plain ElementTree over a file the user gave (through :func:`regen.promises.files.parse_xml`: a
size cap, no entity declarations, bounded nesting): no network, no code run.
Imports: the errors, the promises, :mod:`.xosc_data` (what it reads into) and :mod:`.xosc_record`
(and the custom commands of :mod:`.appearance`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from regen.driving.interop.xosc_data import Action, Condition, EntityDecl, Event, ParsedScenario
from regen.driving.interop.xosc_record import (
    WITHOUT_EFFECT,
    bad,
    choice,
    element_class,
    mark,
    named,
    number,
    tag,
    unread,
)
from regen.errors import ConfigError
from regen.promises.files import MAX_BYTES, label, parse_xml, shown

_GIVE = "give an OpenSCENARIO 1.x .xosc file"
_LISTED = 20  # problems named in the message; the rest are counted


_SHAPES = ("step", "linear", "cubic", "sinusoidal")
_DIMENSIONS = ("time", "distance", "rate")
_RULES = ("lessThan", "lessOrEqual", "greaterThan", "greaterOrEqual", "equalTo")


def _world(holder: ET.Element, where: str) -> tuple[float, float, float]:
    """(x, y, heading) of the <Position> in ``holder``, a <WorldPosition> (NaN, named, where it
    is none)."""
    pos = holder.find("Position")
    wp = pos.find("WorldPosition") if pos is not None else None
    if pos is None:
        bad(holder, f"{tag(holder)} in {where} without a <Position>")
    elif wp is None:
        named(pos[0] if len(pos) else pos, f"{where} (regen import reads a <WorldPosition>: x, y, h in the "
                                            "map's coordinates)")
    if wp is None:
        return math.nan, math.nan, math.nan
    return number(wp, "x", where), number(wp, "y", where), number(wp, "h", where, 0.0)


def _entity(obj: ET.Element) -> EntityDecl | None:
    name = obj.get("name", "")
    where = f"ScenarioObject {shown(name)}"
    body = next((c for c in obj if c.tag in ("Vehicle", "Pedestrian", "MiscObject")), None)
    if body is None:
        for c in obj:
            if c.tag not in WITHOUT_EFFECT:
                named(c, where)
        return None
    mark(body)
    kind = {"Vehicle": "vehicle", "Pedestrian": "pedestrian", "MiscObject": "misc"}[body.tag]
    category = body.get({"vehicle": "vehicleCategory", "pedestrian": "pedestrianCategory",
                         "misc": "miscObjectCategory"}[kind], "")
    dims = body.find("BoundingBox/Dimensions")
    size = ((number(dims, "length", where), number(dims, "width", where), number(dims, "height", where))
            if dims is not None else (4.5, 1.8, 1.5))
    props = {p.get("name", ""): p.get("value", "") for p in body.findall("Properties/Property")}
    return EntityDecl(name=name, kind=kind, category=category, role=body.get("role", ""), size=size,
                      properties=props)


def _dynamics(dyn: ET.Element | None, where: str, shape: str, amount: float) -> tuple[str, str, float]:
    """(shape, dimension, value) of an action's dynamics; the given defaults without one."""
    if dyn is None:
        return shape, "time", amount
    shape = choice(dyn, "dynamicsShape", where, _SHAPES, shape)
    dimension = choice(dyn, "dynamicsDimension", where, _DIMENSIONS, "time")
    return shape, dimension, number(dyn, "value", where)


def _speed_action(sa: ET.Element, where: str) -> Action | None:
    target = sa.find("SpeedActionTarget/AbsoluteTargetSpeed")
    if target is None:
        named(sa, f"{where} (regen import reads a <SpeedAction> to an <AbsoluteTargetSpeed>)")
        return None
    shape, dim, amount = _dynamics(sa.find("SpeedActionDynamics"), where, "step", 0.0)
    return Action(kind="speed", target=number(target, "value", where), shape=shape, dimension=dim, amount=amount)


def _trajectory(fta: ET.Element, where: str) -> Action | None:
    traj = fta.find("TrajectoryRef/Trajectory")
    if traj is None:
        traj = fta.find("Trajectory")  # OpenSCENARIO 1.0 form
    if traj is None:
        named(fta, f"{where} (regen import reads an inline <Trajectory>, not a catalog reference)")
        return None
    poly = traj.find("Shape/Polyline")
    if poly is None:
        shape = traj.find("Shape")
        named(shape[0] if shape is not None and len(shape) else traj, f"{where} (regen import reads a <Polyline>)")
        return None
    timing = fta.find("TimeReference/Timing")
    if timing is None:
        bad(fta, f"a trajectory without a <TimeReference><Timing> in {where} (regen import replays timed "
                  "trajectories: give each vertex a time and a <Timing>)")
        return None
    scale, offset = number(timing, "scale", where, 1.0), number(timing, "offset", where, 0.0)
    relative = choice(timing, "domainAbsoluteRelative", where, ("absolute", "relative"), "absolute") == "relative"
    verts = []
    for v in poly.findall("Vertex"):
        x, y, h = _world(v, where)
        verts.append((number(v, "time", where) * scale + offset, x, y, h))
    if len(verts) < 2 or any(b[0] <= a[0] for a, b in zip(verts, verts[1:], strict=False)):
        bad(fta, f"the trajectory in {where} (it needs at least two vertices with increasing times)")
        return None
    return Action(kind="trajectory", vertices=tuple(verts), relative=relative)


def _lane_change(lca: ET.Element, where: str, actor: str) -> Action | None:
    target = lca.find("LaneChangeTarget/RelativeTargetLane")
    if target is None:
        named(lca, f"{where} (regen import reads a <LaneChangeAction> to a <RelativeTargetLane>)")
        return None
    ref = target.get("entityRef", actor)
    if ref != actor and not ref.startswith("$"):
        bad(target, f"entityRef={shown(ref)} of <RelativeTargetLane> in {where} (regen import reads a lane change "
                     "relative to the actor's own lane)")
    shape, dim, amount = _dynamics(lca.find("LaneChangeActionDynamics"), where, "sinusoidal", 3.0)
    return Action(kind="lane_change", target=number(target, "value", where), shape=shape, dimension=dim,
                  amount=amount)


_LIGHTS = {"specialPurposeLights": "siren", "warningLights": "hazard_lights"}


def _appearance(ap: ET.Element, where: str) -> Action | None:
    """A door's animation or a siren's or hazard lights' light state (OpenSCENARIO 1.2)."""
    if (ls := ap.find("LightStateAction")) is not None:
        light = ls.find("LightType/VehicleLight")
        key = _LIGHTS.get(light.get("vehicleLightType", "") if light is not None else "")
        mode = ls.find("LightState")
        if key is None or mode is None:
            named(ls, f"{where} (only special purpose and warning lights are read)")
            return None
        return Action(kind="state", key=key, state="off" if mode.get("mode") == "off" else "on")
    comp = ap.find("AnimationAction/AnimationType/ComponentAnimation/VehicleComponent")
    if comp is not None and comp.get("vehicleComponentType", "").startswith("door"):
        anim = ap.find("AnimationAction/AnimationState")
        opened = anim is not None and number(anim, "state", where, 0.0) >= 0.5
        return Action(kind="state", key="door", state="open" if opened else "closed")
    named(ap[0] if len(ap) else ap, f"{where} (only door animations are read)")
    return None


def _command(ud: ET.Element, where: str) -> Action | None:
    """A ``UserDefinedAction`` this project writes (a door, a siren, hazard lights)."""
    from regen.driving.interop.appearance import read_command

    cc = ud.find("CustomCommandAction")
    got = read_command(cc.get("type", ""), cc.text or "") if cc is not None else None
    if got is None:
        named(cc if cc is not None else ud, f"{where} (custom commands other than regen:door, regen:siren, "
                                             "regen:hazard_lights)")
        return None
    entity, key, value = got
    return Action(kind="state", key=key, state=value, entity=entity)


def _private(pa: ET.Element, where: str, actor: str) -> Action | None:
    if (ap := pa.find("AppearanceAction")) is not None:
        return _appearance(ap, where)
    if (sa := pa.find("LongitudinalAction/SpeedAction")) is not None:
        return _speed_action(sa, where)
    if (fta := pa.find("RoutingAction/FollowTrajectoryAction")) is not None:
        return _trajectory(fta, where)
    if (lca := pa.find("LateralAction/LaneChangeAction")) is not None:
        return _lane_change(lca, where, actor)
    named(pa[0] if len(pa) else pa, where)
    return None


def _signal(ga: ET.Element, where: str) -> Action | None:
    """A ``TrafficSignalStateAction`` inside a ``GlobalAction`` (None: another global action, or
    one without a name or state, named)."""
    tss = ga.find("InfrastructureAction/TrafficSignalAction/TrafficSignalStateAction")
    if tss is None:
        named(ga[0] if len(ga) else ga, where)
        return None
    if not tss.get("name") or not tss.get("state"):
        bad(tss, f"<TrafficSignalStateAction> in {where} without a name (the signal's id) and a state")
        return None
    return Action(kind="signal", signal=tss.get("name", ""), state=tss.get("state", ""))


def _condition(c: ET.Element, where: str) -> Condition | None:
    got = _condition_body(c, where)
    delay = number(c, "delay", where, 0.0)
    if got is None or delay == 0.0:
        return got
    if delay < 0:
        bad(c, f"delay={shown(c.get('delay') or '')} of {tag(c)} in {where} (a negative delay)")
    return Condition(got.kind, got.value, got.rule, got.entity, got.ref, got.point, delay)


def _condition_body(c: ET.Element, where: str) -> Condition | None:
    if (st := c.find("ByValueCondition/SimulationTimeCondition")) is not None:
        return Condition("time", number(st, "value", where), choice(st, "rule", where, _RULES, "greaterOrEqual"))
    be = c.find("ByEntityCondition")
    inner = be.find("EntityCondition") if be is not None else None
    if be is None or inner is None or not len(inner):
        named(c[0] if len(c) else c, where)
        return None
    refs = [r.get("entityRef", "") for r in be.findall("TriggeringEntities/EntityRef")]
    if len(refs) != 1:
        bad(be, f"a condition with {len(refs)} triggering entities in {where} (regen import reads one)")
        return None
    cond = inner[0]
    if cond.tag not in ("DistanceCondition", "TimeToCollisionCondition", "SpeedCondition",
                        "RelativeDistanceCondition"):
        named(cond, where)
        return None
    mark(cond)
    rule = choice(cond, "rule", where, _RULES, "lessOrEqual")
    if cond.tag == "DistanceCondition":
        x, y, _ = _world(cond, where)
        return Condition("distance", number(cond, "value", where), rule, entity=refs[0], point=(x, y))
    if cond.tag == "TimeToCollisionCondition":
        target = cond.find("TimeToCollisionConditionTarget")
        if target is None or target.find("Position") is None:
            named(target if target is not None else cond, f"{where} (regen import reads a "
                                                           "<TimeToCollisionCondition> to a <Position>)")
            return None
        x, y, _ = _world(target, where)
        return Condition("ttc", number(cond, "value", where), rule, entity=refs[0], point=(x, y))
    if cond.tag == "SpeedCondition":
        return Condition("speed", number(cond, "value", where), rule, entity=refs[0])
    choice(cond, "relativeDistanceType", where, ("longitudinal",), "longitudinal")  # RelativeDistanceCondition
    return Condition("offset", number(cond, "value", where), rule, entity=refs[0], ref=cond.get("entityRef", ""))


def _groups(trigger: ET.Element | None, where: str) -> list[list[Condition]]:
    if trigger is None:
        return []
    out = []
    for g in trigger.findall("ConditionGroup"):
        conds = [_condition(c, where) for c in g.findall("Condition")]
        out.append([c for c in conds if c is not None])
    return [g for g in out if g]


def _act_starts_at_zero(act: ET.Element, where: str) -> None:
    for g in _groups(act.find("StartTrigger"), where):
        if not all(c.kind == "time" and c.value <= 0.0 for c in g):
            bad(act, f"an <Act> start condition other than time 0 in {where}")


def read_xosc(path: str | Path) -> ParsedScenario:
    """The scenario in ``path`` (see the module docstring). Raises ConfigError with one line: an
    unreadable file, a missing part, or everything regen import does not read in it."""
    path = Path(path)
    name = label(path)
    element = element_class()
    root = parse_xml(path, give=_GIVE, limit=MAX_BYTES, element=element)
    rec = element.record
    rec.read.add(id(root))
    header = root.find("FileHeader")
    if root.tag != "OpenSCENARIO" or header is None or header.get("revMajor") != "1":
        raise ConfigError(f"{name}: not an OpenSCENARIO 1.x file (no <OpenSCENARIO> with a FileHeader of revMajor 1)")
    description = header.get("description", "")
    board = root.find("Storyboard")
    if board is None:
        raise ConfigError(f"{name}: no <Storyboard>; a scenario definition is needed (catalogs and "
                          "parameter-value distributions are not scenarios)")
    logic = root.find("RoadNetwork/LogicFile")
    filepath = logic.get("filepath", "") if logic is not None else ""
    map_file = (path.parent / filepath).resolve() if filepath and not filepath.startswith("$") else None
    entities = _entities(root)
    init = _Init.read(board)
    events = _events(board)
    stop = _stop_time(board)
    problems = list(dict.fromkeys([*rec.bad, *unread(root, rec)]))
    if problems:
        more = f"; and {len(problems) - _LISTED} more" if len(problems) > _LISTED else ""
        raise ConfigError(f"{name}: regen import does not read " + "; ".join(problems[:_LISTED]) + more
                          + ". Remove these or write them with what docs/interop.md lists")
    _check_declared(name, entities, init.start, events)
    return ParsedScenario(path=path, description=description, map_file=map_file,
                          entities=entities, start=init.start, speed=init.speed, events=events, stop_time=stop,
                          signals=init.signals, states=init.states)


def _entities(root: ET.Element) -> dict[str, EntityDecl]:
    """The declared entities by name (an ``EntitySelection`` is named as not read)."""
    entities: dict[str, EntityDecl] = {}
    for obj in root.findall("Entities/ScenarioObject"):
        e = _entity(obj)
        if e is not None:
            entities[e.name] = e
    for other in root.findall("Entities/EntitySelection"):
        named(other, "Entities")
    return entities


@dataclass
class _Init:
    """What the storyboard's ``Init`` sets (the fields of :class:`ParsedScenario` of the same names)."""

    start: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    speed: dict[str, float] = field(default_factory=dict)
    states: dict[str, dict[str, str]] = field(default_factory=dict)
    signals: dict[str, str] = field(default_factory=dict)

    @classmethod
    def read(cls, board: ET.Element) -> _Init:
        """Each entity's start pose, speed and states, and the signals' states, from ``Init``."""
        init = cls()
        for priv in board.findall("Init/Actions/Private"):
            entity = priv.get("entityRef", "")
            where = f"Init of {shown(entity)}"
            for pa in priv.findall("PrivateAction"):
                if (tp := pa.find("TeleportAction")) is not None:
                    init.start[entity] = _world(tp, where)
                elif (sa := pa.find("LongitudinalAction/SpeedAction")) is not None:
                    if (got := _speed_action(sa, where)) is not None:
                        init.speed[entity] = got.target
                elif (ap := pa.find("AppearanceAction")) is not None:
                    if (got := _appearance(ap, where)) is not None:
                        init.states.setdefault(entity, {})[got.key] = got.state
                else:
                    named(pa[0] if len(pa) else pa, where)
        for ud in board.findall("Init/Actions/UserDefinedAction"):
            if (cmd := _command(ud, "Init")) is not None:
                init.states.setdefault(cmd.entity, {})[cmd.key] = cmd.state
        for ga in board.findall("Init/Actions/GlobalAction"):
            if (sig := _signal(ga, "Init")) is not None:
                init.signals[sig.signal] = sig.state
        return init


def _events(board: ET.Element) -> list[Event]:
    """The events of every Story/Act/ManeuverGroup/Maneuver, in file order (a maneuver group
    with other than one actor is named, and its events left out)."""
    events: list[Event] = []
    for story in board.findall("Story"):
        for act in story.findall("Act"):
            _act_starts_at_zero(act, f"Act {shown(act.get('name') or '')}")
            for mg in act.findall("ManeuverGroup"):
                actors = [r.get("entityRef", "") for r in mg.findall("Actors/EntityRef")]
                if len(actors) != 1:
                    bad(mg, f"{tag(mg)} with {len(actors)} actors (regen import reads one actor per maneuver "
                             "group)")
                for ev in mg.findall("Maneuver/Event"):
                    where = f"Event {shown(ev.get('name') or '')}"
                    actions = [got for a in ev.findall("Action")
                               if (got := _action(a, where, actors[0] if actors else "")) is not None]
                    groups = _groups(ev.find("StartTrigger"), where)
                    if len(actors) == 1:
                        events.append(Event(actor=actors[0], name=ev.get("name", ""), actions=actions, groups=groups))
    return events


def _stop_time(board: ET.Element) -> float | None:
    """When the ``StopTrigger`` ends the scenario [s] (the earliest of its time conditions), or None."""
    stop = None
    for g in _groups(board.find("StopTrigger"), "StopTrigger"):
        for c in g:
            if c.kind == "time":
                stop = c.value + c.delay if stop is None else min(stop, c.value + c.delay)
            else:
                bad(board, f"a {c.kind} condition in the <StopTrigger> (regen import reads a "
                            "<SimulationTimeCondition> there)")
    return stop


def _check_declared(name: str, entities: dict[str, EntityDecl], start: dict[str, tuple[float, float, float]],
                    events: list[Event]) -> None:
    """ConfigError for an entity the storyboard uses but does not declare, or one without a start."""
    for used in list(start) + [e.actor for e in events]:
        if used not in entities:
            raise ConfigError(f"{name}: {shown(used)} is used in the storyboard but not declared in <Entities>")
    missing = [n for n in entities if n not in start]
    if missing:
        raise ConfigError(f"{name}: no start position for {', '.join(map(shown, missing))}; give each entity a "
                          "TeleportAction to a WorldPosition in <Init>")


def _action(a: ET.Element, where: str, actor: str) -> Action | None:
    """One ``Action`` of an event (None: named as not read)."""
    if (ga := a.find("GlobalAction")) is not None:
        return _signal(ga, where)
    if (ud := a.find("UserDefinedAction")) is not None:
        return _command(ud, where)
    if (pa := a.find("PrivateAction")) is not None:
        return _private(pa, where, actor)
    named(a[0] if len(a) else a, where)
    return None


__all__ = ["read_xosc"]
