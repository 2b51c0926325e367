"""Read an OpenSCENARIO 1.x file into plain data: entities, their start, their events.

What is read (everything else is named in one :class:`~regen.errors.ConfigError` that lists each
element and where it is, never dropped silently):

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
  ``regen:siren``, ``regen:hazard_lights``; :mod:`regen.driving.export.appearance`) and, from
  OpenSCENARIO 1.3 files, ``AppearanceAction``: a door's ``AnimationAction``, the
  ``LightStateAction`` of special purpose lights (a siren) and warning lights (hazard lights);
- start conditions (with their delays): ``SimulationTimeCondition``, ``DistanceCondition`` and
  ``TimeToCollisionCondition`` to a ``WorldPosition``, ``SpeedCondition``,
  ``RelativeDistanceCondition`` (longitudinal); condition groups are OR-ed, conditions within a
  group AND-ed;
- ``StopTrigger``: a ``SimulationTimeCondition``.

Plain ElementTree over a file the user gave: no entity expansion, no network, no code run.
Imports: the errors only.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from regen.errors import ConfigError

MAX_BYTES = 50_000_000  # a scenario file larger than this is refused (it is not one)


@dataclass(frozen=True)
class Condition:
    """One start condition. ``kind``: 'time', 'distance', 'ttc', 'speed' or 'offset'."""

    kind: str
    value: float
    rule: str  # 'lessThan', 'lessOrEqual', 'greaterThan', 'greaterOrEqual', 'equalTo'
    entity: str = ""  # the triggering entity (entity conditions)
    ref: str = ""  # the reference entity (offset)
    point: tuple[float, float] | None = None  # the position (distance, ttc)
    delay: float = 0.0  # [s] after the condition holds


@dataclass(frozen=True)
class Action:
    """One action. ``kind``: 'trajectory', 'speed', 'lane_change' (motion), 'signal' (a traffic
    signal of the map switches to ``state``) or 'state' (the actor's property ``key`` becomes
    ``state``: a door, a siren, hazard lights)."""

    kind: str
    # trajectory: (t [s], x [m], y [m], heading [rad]) vertices; relative: times from the event's start
    vertices: tuple[tuple[float, float, float, float], ...] = ()
    relative: bool = False
    target: float = 0.0  # speed [m/s], or lanes to the left (lane_change; negative: right)
    shape: str = "step"  # step, linear, cubic, sinusoidal
    dimension: str = "time"  # time [s], distance [m], rate [m/s^2]
    amount: float = 0.0  # the dynamics' value in its dimension
    signal: str = ""  # the signal's id in the map (signal)
    state: str = ""  # its new state (signal, state)
    key: str = ""  # the property it sets (state): door, siren, hazard_lights
    entity: str = ""  # whose property (state; empty: the event's actor)


@dataclass
class Event:
    actor: str
    name: str
    actions: list[Action]
    groups: list[list[Condition]]  # OR of ANDs; empty: starts with its act

    @property
    def at_start(self) -> bool:
        """Whether it starts with the scenario (no condition, or time >= 0)."""
        return not self.groups or any(
            all(c.kind == "time" and c.value <= 0.0 and c.rule in ("greaterOrEqual", "greaterThan") for c in g)
            for g in self.groups)


@dataclass
class EntityDecl:
    name: str
    kind: str  # 'vehicle', 'pedestrian', 'misc'
    category: str  # vehicleCategory, pedestrianCategory or miscObjectCategory
    role: str = ""  # Vehicle@role (OpenSCENARIO 1.2), e.g. 'ambulance', 'police'
    size: tuple[float, float, float] = (4.5, 1.8, 1.5)  # length, width, height [m]
    properties: dict[str, str] = field(default_factory=dict)


@dataclass
class ParsedScenario:
    path: Path
    description: str
    map_file: Path | None
    entities: dict[str, EntityDecl]
    start: dict[str, tuple[float, float, float]]  # name -> (x, y, heading)
    speed: dict[str, float]  # name -> start speed [m/s]
    events: list[Event]
    stop_time: float | None
    signals: dict[str, str] = field(default_factory=dict)  # signal id -> its state at the start
    states: dict[str, dict[str, str]] = field(default_factory=dict)  # entity -> property -> state at the start


class _Unsupported(list):
    def add(self, el: ET.Element, where: str) -> None:
        self.append(f"<{el.tag}> in {where}")


def _f(el: ET.Element, attr: str, where: str) -> float:
    raw = el.get(attr)
    if raw is None:
        raise ConfigError(f"{where}: <{el.tag}> has no {attr}; write it as a number")
    if raw.startswith("$"):
        raise ConfigError(f"{where}: {attr}={raw!r} is a parameter reference; regen import reads literal "
                          "values only: substitute the parameter's value")
    try:
        return float(raw)
    except ValueError:
        raise ConfigError(f"{where}: {attr}={raw!r} of <{el.tag}> is not a number") from None


def _world(pos: ET.Element | None, where: str) -> tuple[float, float, float]:
    """(x, y, heading) of a <Position> holding a <WorldPosition>."""
    wp = pos.find("WorldPosition") if pos is not None else None
    if wp is None:
        inner = pos[0].tag if pos is not None and len(pos) else "nothing"
        raise ConfigError(f"{where}: the position is a <{inner}>; regen import reads <WorldPosition> "
                          "(x, y, h in the map's coordinates)")
    return _f(wp, "x", where), _f(wp, "y", where), float(wp.get("h", "0") or 0)


def _entity(obj: ET.Element, bad: _Unsupported) -> EntityDecl | None:
    name = obj.get("name", "")
    where = f"ScenarioObject {name!r}"
    body = next((c for c in obj if c.tag in ("Vehicle", "Pedestrian", "MiscObject")), None)
    if body is None:
        for c in obj:
            if c.tag != "ObjectController":
                bad.add(c, where)
        return None
    kind = {"Vehicle": "vehicle", "Pedestrian": "pedestrian", "MiscObject": "misc"}[body.tag]
    category = body.get({"vehicle": "vehicleCategory", "pedestrian": "pedestrianCategory",
                         "misc": "miscObjectCategory"}[kind], "")
    dims = body.find("BoundingBox/Dimensions")
    size = ((_f(dims, "length", where), _f(dims, "width", where), _f(dims, "height", where))
            if dims is not None else (4.5, 1.8, 1.5))
    props = {p.get("name", ""): p.get("value", "") for p in body.findall("Properties/Property")}
    return EntityDecl(name=name, kind=kind, category=category, role=body.get("role", ""), size=size,
                      properties=props)


def _dynamics(dyn: ET.Element | None, where: str, shape: str, amount: float) -> tuple[str, str, float]:
    """(shape, dimension, value) of an action's dynamics; the given defaults without one."""
    if dyn is None:
        return shape, "time", amount
    return dyn.get("dynamicsShape", shape), dyn.get("dynamicsDimension", "time"), _f(dyn, "value", where)


def _speed_action(sa: ET.Element, where: str) -> Action:
    target = sa.find("SpeedActionTarget/AbsoluteTargetSpeed")
    if target is None:
        raise ConfigError(f"{where}: a <SpeedAction> to a relative target speed; regen import reads "
                          "<AbsoluteTargetSpeed> only")
    shape, dim, amount = _dynamics(sa.find("SpeedActionDynamics"), where, "step", 0.0)
    return Action(kind="speed", target=_f(target, "value", where), shape=shape, dimension=dim, amount=amount)


def _trajectory(fta: ET.Element, where: str) -> Action:
    traj = fta.find("TrajectoryRef/Trajectory")
    if traj is None:
        traj = fta.find("Trajectory")  # OpenSCENARIO 1.0 form
    if traj is None:
        raise ConfigError(f"{where}: a <FollowTrajectoryAction> without an inline <Trajectory> "
                          "(catalog references are not read)")
    poly = traj.find("Shape/Polyline")
    if poly is None:
        shape = traj.find("Shape")
        inner = shape[0].tag if shape is not None and len(shape) else "nothing"
        raise ConfigError(f"{where}: the trajectory's shape is a <{inner}>; regen import reads <Polyline>")
    timing = fta.find("TimeReference/Timing")
    if timing is None:
        raise ConfigError(f"{where}: the trajectory has no <Timing>; regen import replays timed "
                          "trajectories (give each vertex a time and a <Timing>)")
    scale, offset = float(timing.get("scale", "1") or 1), float(timing.get("offset", "0") or 0)
    verts = []
    for v in poly.findall("Vertex"):
        x, y, h = _world(v.find("Position"), where)
        verts.append((_f(v, "time", where) * scale + offset, x, y, h))
    if len(verts) < 2 or any(b[0] <= a[0] for a, b in zip(verts, verts[1:], strict=False)):
        raise ConfigError(f"{where}: a trajectory needs at least two vertices with increasing times")
    return Action(kind="trajectory", vertices=tuple(verts),
                  relative=timing.get("domainAbsoluteRelative", "absolute") == "relative")


def _lane_change(lca: ET.Element, where: str) -> Action:
    target = lca.find("LaneChangeTarget/RelativeTargetLane")
    if target is None:
        raise ConfigError(f"{where}: a <LaneChangeAction> to an absolute lane; regen import reads "
                          "<RelativeTargetLane> (positive: lanes to the left)")
    shape, dim, amount = _dynamics(lca.find("LaneChangeActionDynamics"), where, "sinusoidal", 3.0)
    return Action(kind="lane_change", target=_f(target, "value", where), shape=shape, dimension=dim,
                  amount=amount)


_LIGHTS = {"specialPurposeLights": "siren", "warningLights": "hazard_lights"}


def _appearance(ap: ET.Element, where: str, bad: _Unsupported) -> Action | None:
    """A door's animation or a siren's or hazard lights' light state (OpenSCENARIO 1.2)."""
    if (ls := ap.find("LightStateAction")) is not None:
        light = ls.find("LightType/VehicleLight")
        key = _LIGHTS.get(light.get("vehicleLightType", "") if light is not None else "")
        mode = ls.find("LightState")
        if key is None or mode is None:
            bad.add(ls, f"{where} (only special purpose and warning lights are read)")
            return None
        return Action(kind="state", key=key, state="off" if mode.get("mode") == "off" else "on")
    comp = ap.find("AnimationAction/AnimationType/ComponentAnimation/VehicleComponent")
    if comp is not None and comp.get("vehicleComponentType", "").startswith("door"):
        anim = ap.find("AnimationAction/AnimationState")
        opened = anim is not None and float(anim.get("state", "0") or 0) >= 0.5
        return Action(kind="state", key="door", state="open" if opened else "closed")
    bad.add(ap[0] if len(ap) else ap, f"{where} (only door animations are read)")
    return None


def _command(ud: ET.Element, where: str, bad: _Unsupported) -> Action | None:
    """A ``UserDefinedAction`` this project writes (a door, a siren, hazard lights)."""
    from regen.driving.export.appearance import read_command

    cc = ud.find("CustomCommandAction")
    got = read_command(cc.get("type", ""), cc.text or "") if cc is not None else None
    if got is None:
        bad.add(cc if cc is not None else ud, f"{where} (custom commands other than regen:door, "
                "regen:siren, regen:hazard_lights)")
        return None
    entity, key, value = got
    return Action(kind="state", key=key, state=value, entity=entity)


def _private(pa: ET.Element, where: str, bad: _Unsupported) -> Action | None:
    if (ap := pa.find("AppearanceAction")) is not None:
        return _appearance(ap, where, bad)
    if (sa := pa.find("LongitudinalAction/SpeedAction")) is not None:
        return _speed_action(sa, where)
    if (fta := pa.find("RoutingAction/FollowTrajectoryAction")) is not None:
        return _trajectory(fta, where)
    if (lca := pa.find("LateralAction/LaneChangeAction")) is not None:
        return _lane_change(lca, where)
    bad.add(pa[0] if len(pa) else pa, where)
    return None


_RULES = ("lessThan", "lessOrEqual", "greaterThan", "greaterOrEqual", "equalTo")


def _signal(ga: ET.Element, where: str) -> Action | None:
    """A ``TrafficSignalStateAction`` inside a ``GlobalAction`` (None: another global action)."""
    tss = ga.find("InfrastructureAction/TrafficSignalAction/TrafficSignalStateAction")
    if tss is None:
        return None
    if not tss.get("name") or not tss.get("state"):
        raise ConfigError(f"{where}: a <TrafficSignalStateAction> needs a name (the signal's id) and a state")
    return Action(kind="signal", signal=tss.get("name", ""), state=tss.get("state", ""))


def _condition(c: ET.Element, where: str, bad: _Unsupported) -> Condition | None:
    got = _condition_body(c, where, bad)
    delay = _f(c, "delay", where) if c.get("delay") else 0.0
    if got is None or delay == 0.0:
        return got
    if delay < 0:
        raise ConfigError(f"{where}: a negative condition delay ({delay:g} s)")
    return Condition(got.kind, got.value, got.rule, got.entity, got.ref, got.point, delay)


def _condition_body(c: ET.Element, where: str, bad: _Unsupported) -> Condition | None:
    if (st := c.find("ByValueCondition/SimulationTimeCondition")) is not None:
        return Condition("time", _f(st, "value", where), st.get("rule", "greaterOrEqual"))
    be = c.find("ByEntityCondition")
    inner = be.find("EntityCondition") if be is not None else None
    if be is None or inner is None or not len(inner):
        bad.add(c[0] if len(c) else c, where)
        return None
    refs = [r.get("entityRef", "") for r in be.findall("TriggeringEntities/EntityRef")]
    if len(refs) != 1:
        raise ConfigError(f"{where}: a condition with {len(refs)} triggering entities; regen import reads one")
    cond = inner[0]
    rule = cond.get("rule", "lessOrEqual")
    if rule not in _RULES:
        raise ConfigError(f"{where}: unknown rule {rule!r}; use one of {', '.join(_RULES)}")
    if cond.tag == "DistanceCondition":
        x, y, _ = _world(cond.find("Position"), where)
        return Condition("distance", _f(cond, "value", where), rule, entity=refs[0], point=(x, y))
    if cond.tag == "TimeToCollisionCondition":
        target = cond.find("TimeToCollisionConditionTarget")
        if target is None or target.find("Position") is None:
            raise ConfigError(f"{where}: a <TimeToCollisionCondition> to an entity; regen import reads one "
                              "to a <Position>")
        x, y, _ = _world(target.find("Position"), where)
        return Condition("ttc", _f(cond, "value", where), rule, entity=refs[0], point=(x, y))
    if cond.tag == "SpeedCondition":
        return Condition("speed", _f(cond, "value", where), rule, entity=refs[0])
    if cond.tag == "RelativeDistanceCondition":
        if cond.get("relativeDistanceType", "longitudinal") != "longitudinal":
            raise ConfigError(f"{where}: a <RelativeDistanceCondition> of type "
                              f"{cond.get('relativeDistanceType')!r}; regen import reads 'longitudinal'")
        return Condition("offset", _f(cond, "value", where), rule, entity=refs[0], ref=cond.get("entityRef", ""))
    bad.add(cond, where)
    return None


def _groups(trigger: ET.Element | None, where: str, bad: _Unsupported) -> list[list[Condition]]:
    if trigger is None:
        return []
    out = []
    for g in trigger.findall("ConditionGroup"):
        conds = [_condition(c, where, bad) for c in g.findall("Condition")]
        out.append([c for c in conds if c is not None])
    return [g for g in out if g]


def _act_starts_at_zero(act: ET.Element, where: str, bad: _Unsupported) -> None:
    for g in _groups(act.find("StartTrigger"), where, bad):
        if not all(c.kind == "time" and c.value <= 0.0 for c in g):
            bad.append(f"an <Act> start condition other than time 0 in {where}")


def read_xosc(path: str | Path) -> ParsedScenario:
    """The scenario in ``path`` (see the module docstring). Raises ConfigError with one line per
    problem: an unreadable file, a missing part, and every element regen import does not read."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file; give an OpenSCENARIO .xosc file")
    if path.stat().st_size > MAX_BYTES:
        raise ConfigError(f"{path}: {path.stat().st_size} bytes is too large for a scenario file")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ConfigError(f"{path}: not readable XML ({exc})") from None
    header = root.find("FileHeader")
    if root.tag != "OpenSCENARIO" or header is None or header.get("revMajor") != "1":
        raise ConfigError(f"{path}: not an OpenSCENARIO 1.x file (no <OpenSCENARIO> with a FileHeader of revMajor 1)")
    board = root.find("Storyboard")
    if board is None:
        raise ConfigError(f"{path}: no <Storyboard>; a scenario definition is needed (catalogs and "
                          "parameter-value distributions are not scenarios)")
    bad = _Unsupported()
    logic = root.find("RoadNetwork/LogicFile")
    map_file = (path.parent / logic.get("filepath", "")).resolve() if logic is not None and logic.get("filepath") else None
    entities: dict[str, EntityDecl] = {}
    for obj in root.findall("Entities/ScenarioObject"):
        e = _entity(obj, bad)
        if e is not None:
            entities[e.name] = e
    for other in root.findall("Entities/EntitySelection"):
        bad.add(other, "Entities")
    start: dict[str, tuple[float, float, float]] = {}
    speed: dict[str, float] = {}
    states: dict[str, dict[str, str]] = {}
    for priv in board.findall("Init/Actions/Private"):
        name = priv.get("entityRef", "")
        where = f"Init of {name!r}"
        for pa in priv.findall("PrivateAction"):
            if (tp := pa.find("TeleportAction")) is not None:
                start[name] = _world(tp.find("Position"), where)
            elif (sa := pa.find("LongitudinalAction/SpeedAction")) is not None:
                speed[name] = _speed_action(sa, where).target
            elif (ap := pa.find("AppearanceAction")) is not None:
                got = _appearance(ap, where, bad)
                if got is not None:
                    states.setdefault(name, {})[got.key] = got.state
            else:
                bad.add(pa[0] if len(pa) else pa, where)
    for ud in board.findall("Init/Actions/UserDefinedAction"):
        if (cmd := _command(ud, "Init", bad)) is not None:
            states.setdefault(cmd.entity, {})[cmd.key] = cmd.state
    signals: dict[str, str] = {}
    for ga in board.findall("Init/Actions/GlobalAction"):
        sig = _signal(ga, "Init")
        if sig is None:
            bad.add(ga[0] if len(ga) else ga, "Init")
        else:
            signals[sig.signal] = sig.state
    events: list[Event] = []
    for story in board.findall("Story"):
        for act in story.findall("Act"):
            _act_starts_at_zero(act, f"Act {act.get('name')!r}", bad)
            for mg in act.findall("ManeuverGroup"):
                actors = [r.get("entityRef", "") for r in mg.findall("Actors/EntityRef")]
                for ev in mg.iter("Event"):
                    where = f"Event {ev.get('name')!r}"
                    actions = []
                    for a in ev.findall("Action"):
                        pa = a.find("PrivateAction")
                        ga = a.find("GlobalAction")
                        if ga is not None and (sig := _signal(ga, where)) is not None:
                            actions.append(sig)
                            continue
                        if (ud := a.find("UserDefinedAction")) is not None:
                            if (cmd := _command(ud, where, bad)) is not None:
                                actions.append(cmd)
                            continue
                        if pa is None:
                            bad.add(a[0] if len(a) else a, where)
                            continue
                        got = _private(pa, where, bad)
                        if got is not None:
                            actions.append(got)
                    if len(actors) != 1:
                        raise ConfigError(f"{where}: its maneuver group has {len(actors)} actors; regen import "
                                          "reads one actor per maneuver group")
                    events.append(Event(actor=actors[0], name=ev.get("name", ""), actions=actions,
                                        groups=_groups(ev.find("StartTrigger"), where, bad)))
    stop = None
    for g in _groups(board.find("StopTrigger"), "StopTrigger", bad):
        for c in g:
            if c.kind == "time":
                stop = c.value if stop is None else min(stop, c.value)
    if bad:
        raise ConfigError(f"{path}: regen import does not read " + "; ".join(dict.fromkeys(bad))
                          + ". Remove these or express them with the features listed in docs/interop.md")
    for name in list(start) + [e.actor for e in events]:
        if name not in entities:
            raise ConfigError(f"{path}: {name!r} is used in the storyboard but not declared in <Entities>")
    missing = [n for n in entities if n not in start]
    if missing:
        raise ConfigError(f"{path}: no start position for {', '.join(missing)}; give each entity a "
                          "TeleportAction to a WorldPosition in <Init>")
    return ParsedScenario(path=path, description=header.get("description", ""), map_file=map_file,
                          entities=entities, start=start, speed=speed, events=events, stop_time=stop,
                          signals=signals, states=states)


__all__ = ["Action", "Condition", "EntityDecl", "Event", "ParsedScenario", "read_xosc"]
