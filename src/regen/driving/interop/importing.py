"""``regen import``: an OpenSCENARIO file as a scenario the embedded simulator runs and verifies.

The file is read (:mod:`.xosc_read`) and played kinematically (:mod:`.player`). Then:

- **the ego** (the entity named ``ego``, ``hero`` or ``ego_vehicle``, or with the property
  ``type = ego_vehicle``) replays its played path exactly, as a recorded trajectory does: its
  behavior class (stop, slow-down, start, lane change ...) and event time are detected from
  it (:func:`regen.driving.world.recorded.detect`), which gives the ego's FSM states;
- **every other actor** replays its motion from the start (the events that start with the
  scenario) and, when its *cause event* (the one a condition starts) fires, the motion of that
  event. The condition becomes a trigger on the ego (:mod:`regen.driving.world.triggers`):
  distance or time to a point -> ``near``; the ego's speed below a value -> ``ego_slower``; the
  actor's longitudinal offset from the ego -> ``offset``; simulation time -> ``time``. Another
  ego (``regen test``) sets it off where it is; a condition on other entities starts it at the
  time it started in the file (said in the notes);
- **the FSM** comes from the storyboard: the ego's start state, each cause event's state (the
  actor moves off, brakes, changes lane or moves, as its motion after the condition shows) in
  the order the file starts them, then the ego's reaction states. A verdict is thus "the
  storyboard's causes happened, then the ego reacted".

Assets: ``regen_asset`` when the file says it (our exports), else from the category and role
(an ambulance, a police car, a truck, a bus, a bicycle, a pedestrian, an obstacle); properties
``regen_<name>`` come back as the entity's properties. Maps: the project's generated maps only
(the scenario's ``.xodr`` must be one of them, or named after one and absent).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from regen.core.behavior import Behavior
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.driving.interop.player import Played, delay_of, play
from regen.driving.interop.signals import signals_of, without_signals
from regen.driving.interop.xosc_data import Condition, EntityDecl, Event, ParsedScenario
from regen.driving.interop.xosc_read import read_xosc
from regen.driving.world.imported import imported_entities, with_imported
from regen.driving.world.maps import GEOMETRIES, ensure_map
from regen.driving.world.recorded import CLASSES, Trajectory, detect
from regen.driving.world.replay import recorded_template
from regen.driving.world.setting import (
    DrivingParams,
    DrivingWorld,
    ImportedActor,
    ImportedStoryboard,
    RecordedEgo,
)
from regen.errors import ConfigError
from regen.promises.files import parse_xml

DT = 0.1  # [s] the simulation step
MAX_DURATION = 60.0  # [s] a file without a stop time runs this long at most
MIN_DURATION = 1.0  # [s] a shorter run shows no behavior
EGO_NAMES = ("ego", "hero", "ego_vehicle", "egovehicle")
MOVING = 0.5  # [m/s] an actor slower than this stands
_VEHICLE_ASSET = {"car": "sedan", "van": "truck", "truck": "truck", "trailer": "truck", "semitrailer": "truck",
                  "bus": "bus", "motorbike": "motorcycle", "bicycle": "bicycle", "tram": "bus", "train": "bus"}
_ROLE_ASSET = {"ambulance": "ambulance", "police": "police_car", "fire": "fire_truck"}
_MISC_ASSET = {"barrier": "barrier", "pole": "traffic_light", "obstacle": "traffic_cone"}


def _asset(e: EntityDecl, db) -> str:
    named = e.properties.get("regen_asset", "")
    if named in db.assets:
        return named
    if e.kind == "pedestrian":
        return "child" if e.size[2] < 1.4 and "child" in db.assets else "adult"
    if e.kind == "vehicle":
        return _ROLE_ASSET.get(e.role) or _VEHICLE_ASSET.get(e.category, "sedan")
    return _MISC_ASSET.get(e.category, "traffic_cone")


def _scenario_name(name: str, taken: set[str]) -> str:
    """The file's entity name as a scenario entity's: letters, digits and underscores, not the
    ego's, unique."""
    base = re.sub(r"[^A-Za-z0-9_]", "_", name).strip("_") or "actor"
    if base[0].isdigit() or base.lower() == "ego":
        base = f"actor_{base}"
    out, k = base, 2
    while out in taken:
        out, k = f"{base}_{k}", k + 1
    return out


def _is_ego(e: EntityDecl) -> bool:
    return (e.name.lower() in EGO_NAMES or e.properties.get("type") == "ego_vehicle"
            or e.properties.get("regen_asset") == "ego")


def _map(parsed: ParsedScenario) -> tuple[str, str, dict[str, tuple[str, float, float]]]:
    """(generated map name, how it was recognised, its signals: id -> (name, x, y))."""
    f = parsed.map_file
    if f is None:
        raise ConfigError(f"{parsed.path}: no <RoadNetwork><LogicFile>; regen import runs on the project's "
                          f"generated maps ({', '.join(GEOMETRIES)}): reference one")
    stem = re.sub(r"-v\d+$", "", f.stem)
    if f.exists():  # a folder or a special file too: said in one line by the promise
        root = parse_xml(f, what=f"{parsed.path}: the map", give=f"reference a generated map ({', '.join(GEOMETRIES)}) "
                         "by its name, or put its .xodr beside the file")
        try:
            signals, bad_signal = signals_of(root), ""
        except ValueError as exc:
            signals, bad_signal = {}, str(exc)
        text = without_signals(root)
        for name in GEOMETRIES:
            if without_signals(ensure_map(name).read_text(encoding="utf-8")) == text:
                if bad_signal:
                    raise ConfigError(f"{parsed.path}: the map {f.name}: {bad_signal}; write each <signal>'s s and t "
                                      "as numbers [m] (or remove the signal)")
                extra = f" with {len(signals)} signal(s)" if signals else ""
                return name, f"{f.name} is the generated map {name}{extra}", signals
        raise ConfigError(f"{parsed.path}: the map {f.name} is not one of the project's generated maps "
                          f"({', '.join(GEOMETRIES)}); the embedded simulator runs scenarios on those only")
    if stem in GEOMETRIES:
        return stem, f"{f.name} is not beside the file; its name is the generated map {stem}", {}
    raise ConfigError(f"{parsed.path}: the map {f} does not exist; reference a generated map "
                      f"({', '.join(GEOMETRIES)}) by its name")


def _spec(ev: Event, ego: str, parsed: ParsedScenario) -> tuple | None:
    """The trigger the simulation uses for a cause event (None: its conditions are on other
    entities, or combined in a way no trigger kind states)."""
    groups = ev.groups
    flat = [c for g in groups for c in g]
    if any(len(g) != 1 for g in groups) or not flat:
        return None
    kinds = {c.kind for c in flat}
    h = parsed.start[ego][2]
    ux, uy = math.cos(h), math.sin(h)
    on_ego = all(c.entity == ego for c in flat if c.kind in ("distance", "ttc", "speed"))
    if kinds == {"time"} and len(flat) == 1:
        return ("time", flat[0].value, 0.0, 0.0, ux, uy, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if kinds <= {"distance", "ttc"} and on_ego and len({c.point for c in flat}) == 1 and len(flat) <= 2:
        if any(c.rule not in ("lessThan", "lessOrEqual") for c in flat):
            return None
        near = next((c.value for c in flat if c.kind == "distance"), -1.0)
        tta = next((c.value for c in flat if c.kind == "ttc"), 0.0)
        px, py = flat[0].point  # type: ignore[misc]
        return ("near", 0.0, px, py, ux, uy, near, tta, 0.0, 0.0, 0.0, 0.0)
    if kinds == {"speed"} and on_ego and len(flat) == 1 and flat[0].rule in ("lessThan", "lessOrEqual"):
        return ("ego_slower", 0.0, 0.0, 0.0, ux, uy, 0.0, 0.0, flat[0].value, 0.0, 0.0, 0.0)
    offsets = [c for c in flat if c.kind == "offset"]
    times = [c for c in flat if c.kind == "time"]
    if (len(offsets) == 1 and len(flat) == len(offsets) + len(times) <= 2 and offsets[0].entity == ev.actor
            and offsets[0].ref == ego and offsets[0].rule != "equalTo"):
        rate = 1.0 if offsets[0].rule in ("greaterThan", "greaterOrEqual") else -1.0
        late = times[0].value if times else 1e9
        return ("offset", 0.0, 0.0, 0.0, ux, uy, 0.0, 0.0, 0.0, offsets[0].value, rate, late)
    return None


def _words(c: Condition, ego: str) -> str:
    rule = {"lessThan": "less than", "lessOrEqual": "at most", "greaterThan": "more than",
            "greaterOrEqual": "at least", "equalTo": "exactly"}[c.rule]
    who = "the ego" if c.entity == ego else c.entity
    if c.kind == "time":
        return f"the time is {rule} {round(c.value, 1):g} s"
    if c.kind == "distance":
        return f"{who} is {rule} {round(c.value, 1):g} m from ({c.point[0]:.1f}, {c.point[1]:.1f})"  # type: ignore[index]
    if c.kind == "ttc":
        return f"{who} is {rule} {round(c.value, 1):g} s from ({c.point[0]:.1f}, {c.point[1]:.1f})"  # type: ignore[index]
    if c.kind == "speed":
        return f"{who}'s speed is {rule} {round(c.value, 1):g} m/s"
    return f"{who} is {rule} {round(c.value, 1):g} m ahead of {'the ego' if c.ref == ego else c.ref}"


def condition_words(ev: Event, ego: str) -> str:
    return " or ".join(" and ".join(_words(c, ego) for c in g) for g in ev.groups) or "the scenario starts"


def _relative(poses: list, at: tuple[float, float, float, float]) -> list[tuple[float, float, float, float]]:
    x0, y0, h0, _ = at
    c, s = math.cos(h0), math.sin(h0)
    return [(round((x - x0) * c + (y - y0) * s, 4), round(-(x - x0) * s + (y - y0) * c, 4),
             round(h - h0, 5), round(v, 4)) for x, y, h, v in poses]


def _rounded(poses: list) -> list[tuple[float, float, float, float]]:
    return [(round(x, 4), round(y, 4), round(h, 5), round(v, 4)) for x, y, h, v in poses]


def _cause_state(actor: ImportedActor, kind: str) -> tuple[str, list[PredicateCall]]:
    """The state a cause event's motion shows (from its poses after the condition fired)."""
    poses = actor.after if actor.relative else _relative(actor.after, actor.after[0]) if actor.after else []
    if not poses:
        return "acting", [PredicateCall(name="slower_than", args=[actor.name], params={"max_speed": 1e6})]
    v = np.array([p[3] for p in poses])
    side = max(abs(p[1]) for p in poses)
    if kind == "vehicle" and side > 1.5:
        return "changing_lane", [PredicateCall(name="changing_lane", args=[actor.name])]
    if v[0] < MOVING and v.max() >= 1.0:
        return "moving_off", [PredicateCall(name="slower_than", args=[actor.name], params={"max_speed": MOVING},
                                            negate=True)]
    if v.min() < v[0] - 2.0:
        return "braking", [PredicateCall(name="braking", args=[actor.name], params={"min_decel": 1.0})]
    return "moving", [PredicateCall(name="slower_than", args=[actor.name], params={"max_speed": MOVING}, negate=True)]


def _action_words(state: str) -> str:
    return {"changing_lane": "changes lanes", "moving_off": "starts moving", "braking": "brakes",
            "moving": "moves", "acting": "acts"}[state]


def import_xosc(path: str | Path, *, dt: float = DT) -> Scenario:
    """The scenario of an OpenSCENARIO file (see the module docstring); ConfigError with one
    line for everything it cannot read or run."""
    from regen.driving.assets import database

    parsed = read_xosc(path)
    db = database()
    ego = _the_ego(parsed)
    map_name, map_words, map_signals = _map(parsed)
    duration = _duration(parsed)
    notes = [map_words]
    if parsed.stop_time is None:
        notes.append(f"no stop time: it runs {MAX_DURATION:g} s")
    causes = _cause_events(parsed, ego)
    specs = {ev.name: _spec(ev, ego, parsed) for ev in causes.values()}
    played = play(parsed, ego=ego, dt=dt, duration=duration, specs=specs)
    notes += _start_as_played(parsed, causes, specs, played, ego, dt)
    rec = _recorded_ego(parsed, played, ego, map_name, dt)
    start_only = {ev.name for ev in parsed.events if ev.at_start}
    base = play(parsed, ego=ego, dt=dt, duration=duration, only=start_only)
    actors: list[ImportedActor] = []
    texts: list[str] = []
    for name, decl in parsed.entities.items():
        if name == ego:
            continue
        actor, text = _actor(name, decl, causes.get(name), specs, played, base, ego, db,
                             taken={a.name for a in actors}, notes=notes)
        actors.append(actor)
        texts += [text] if text else []
    texts = _state_events(parsed, played, map_signals, actors, ego, notes) + texts
    board = ImportedStoryboard(source=Path(path).name, map=map_name, dt=dt, duration=duration, actors=actors,
                               notes=notes)
    return _scenario(Path(path), rec, board, texts)


def _the_ego(parsed: ParsedScenario) -> str:
    """The name of the file's one ego entity; ConfigError when there is none or several."""
    egos = [n for n, e in parsed.entities.items() if _is_ego(e)]
    if len(egos) != 1:
        raise ConfigError(f"{parsed.path}: {'no' if not egos else len(egos)} ego entities; name exactly one "
                          f"entity {' or '.join(EGO_NAMES[:3])} (or give it the property type = ego_vehicle)")
    return egos[0]


def _duration(parsed: ParsedScenario) -> float:
    """How long [s] the scenario runs: its stop time, at most MAX_DURATION; ConfigError when too short."""
    duration = min(parsed.stop_time if parsed.stop_time is not None else MAX_DURATION, MAX_DURATION)
    if duration < MIN_DURATION:
        raise ConfigError(f"{parsed.path}: its <StopTrigger> ends the scenario at {parsed.stop_time:g} s; regen import "
                          f"plays at least {MIN_DURATION:g} s: give a later SimulationTimeCondition")
    return duration


def _cause_events(parsed: ParsedScenario, ego: str) -> dict[str, Event]:
    """Actor -> its cause event: the one a condition starts that moves it (one per actor)."""
    causes: dict[str, Event] = {}
    for ev in parsed.events:
        if ev.actor == ego or ev.at_start or all(a.kind in ("signal", "state") for a in ev.actions):
            continue
        if ev.actor in causes:
            raise ConfigError(f"{parsed.path}: {ev.actor!r} has two events started by conditions "
                              f"({causes[ev.actor].name!r}, {ev.name!r}); regen import reads one cause event per actor")
        causes[ev.actor] = ev
    return causes


def _start_as_played(parsed: ParsedScenario, causes: dict[str, Event], specs: dict[str, tuple | None],
                     played: Played, ego: str, dt: float) -> list[str]:
    """Give each cause event that no trigger states (``specs`` None) a time trigger at the time
    it started in the file's own run; returns the notes that say so."""
    notes = []
    for ev in causes.values():
        if specs[ev.name] is None:
            k = played.started.get(ev.name)
            if k is None:
                raise ConfigError(f"{parsed.path}: the event {ev.name!r} of {ev.actor!r} never starts in the file's "
                                  f"own run ({condition_words(ev, ego)}); regen import needs it to start once")
            specs[ev.name] = ("time", round(k * dt, 4), 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            notes.append(f"{ev.actor}'s event {ev.name!r} starts on {condition_words(ev, ego)}, which is not a "
                         f"condition on the ego alone: it starts at {k * dt:.1f} s, when it started in the file")
    return notes


def _actor(name: str, decl: EntityDecl, ev: Event | None, specs: dict[str, tuple | None], played: Played,
           base: Played, ego: str, db, *, taken: set[str], notes: list[str]) -> tuple[ImportedActor, str]:
    """One entity of the file other than the ego as an imported actor: its motion from the start
    (``base``), its cause event's motion, trigger and state, and the cause text it adds ('' when
    none). A cause event that never started in the file's own run is noted in ``notes``."""
    asset = _asset(decl, db)
    props = {k[len("regen_"):]: v for k, v in decl.properties.items()
             if k.startswith("regen_") and k != "regen_asset" and k[len("regen_"):] in db.properties}
    actor = ImportedActor(name=_scenario_name(name, taken), source=name, asset=asset,
                          properties=props, before=_rounded(base.poses[name]))
    if ev is not None:
        k = played.started.get(ev.name)
        if k is None:
            notes.append(f"{name}'s event {ev.name!r} never started in the file's own run")
        else:
            after = played.poses[name][k:]
            trajectory = any(a.kind == "trajectory" for a in ev.actions)
            actor.after = _rounded(after) if trajectory else _relative(after, after[0])
            actor.relative = not trajectory
        actor.trigger = specs[ev.name]
        actor.event, actor.condition = ev.name, condition_words(ev, ego)
    moving = max(p[3] for p in actor.before + actor.after) >= MOVING
    actor.kind = "agent" if moving or decl.kind != "misc" else "object"
    if ev is None or not actor.after:
        return actor, ""
    state, calls = _cause_state(actor, decl.kind)
    actor.action = _action_words(state)
    actor.cause = AbstractState(name=state, actor=actor.name, all_of=calls, cause=True)
    return actor, f"the {asset.replace('_', ' ')} {actor.action} when {actor.condition}"


def _scenario(path: Path, rec: RecordedEgo, board: ImportedStoryboard, texts: list[str]) -> Scenario:
    """The imported scenario: the ego replays its recorded path, the actors the storyboard; the
    cause is the storyboard's cause texts, the behavior the one detected in the ego's path."""
    behavior_text = CLASSES[rec.detected][1]
    behavior = Behavior(text=behavior_text, domain="driving",
                        params=DrivingParams(recorded=rec, imported=board).model_dump(exclude_none=True))
    t = recorded_template(rec)
    entities = [Entity(name="ego", asset="ego", kind="robot", behavior=t.id,
                       behavior_params={"text": behavior_text}), *imported_entities(board)]
    fsm = with_imported(_ego_fsm(t), board, {n for n, _ in t.ego_states()[1]})
    cause = " and ".join(texts) if texts else f"the storyboard of {path.name}"
    world = DrivingWorld(map=board.map, ego_template=t.id, duration=board.duration, dt=board.dt, grounder="imported")
    return Scenario(id=f"import-{re.sub(r'[^A-Za-z0-9_-]', '_', path.stem)[:40]}", domain="driving",
                    behavior=behavior, causal_graph=[cause, behavior_text],
                    narrative=f"{cause[0].upper()}{cause[1:]}, so {behavior_text}.", entities=entities, fsm=fsm,
                    world=world.as_world(), fsm_source="rules")


_STATE_PREDICATES = {("door", "open"): "door_open", ("siren", "on"): "siren_on", ("hazard_lights", "on"): "hazard_lights_on"}


def _state_events(parsed: ParsedScenario, played: Played, map_signals: dict[str, tuple[str, float, float]],
                  actors: list[ImportedActor], ego: str, notes: list[str]) -> list[str]:
    """The states the storyboard switches: a traffic signal of the map (its light: the entity
    the signal is named after, as the exporter writes it, else a traffic light where the map
    has the signal) and an actor's door, siren or hazard lights. Each property's changes run on
    the trigger of their events' common condition (each change its delay after), else at the
    times they happened in the file's own run. Returns the cause texts."""
    changes: dict[tuple[str, str], list[tuple[Event, str]]] = {}  # (actor source or signal id, key)
    for ev in parsed.events:
        for a in ev.actions:
            if a.kind == "signal":
                changes.setdefault((f"signal:{a.signal}", "light_state"), []).append((ev, a.state))
            elif a.kind == "state" and (a.entity or ev.actor) != ego:
                changes.setdefault((a.entity or ev.actor, a.key), []).append((ev, a.state))
    for sid in parsed.signals:
        changes.setdefault((f"signal:{sid}", "light_state"), [])
    by_source = {a.source: a for a in actors}
    for owner, states in parsed.states.items():  # a state set at the start and never changed
        for key, value in states.items():
            if (owner, key) not in changes and owner in by_source:
                by_source[owner].properties[key] = value
    texts = []
    for (owner, key), evs in sorted(changes.items()):
        if owner.startswith("signal:"):
            sid = owner[len("signal:"):]
            name, x, y = map_signals.get(sid, ("", 0.0, 0.0))
            actor = by_source.get(name)
            if actor is None:
                if sid not in map_signals:
                    raise ConfigError(f"{parsed.path}: the storyboard switches the signal {sid!r}, which the map "
                                      "does not have (OpenDRIVE <signal id>)")
                actor = ImportedActor(name=f"signal_{sid}", source=f"signal {sid} of the map", asset="traffic_light",
                                      kind="object", before=[(round(x, 4), round(y, 4), 0.0, 0.0)])
                actors.append(actor)
                by_source[actor.source] = actor
            init = parsed.signals.get(sid) or (evs[0][1] if evs else "off")
            played_key = sid
        else:
            actor = by_source.get(owner)
            if actor is None:
                raise ConfigError(f"{parsed.path}: the storyboard sets {key} of {owner!r}, which is not an entity")
            sid = ""
            init = parsed.states.get(owner, {}).get(key) or actor.properties.get(key) or (
                {"door": "closed"}.get(key, "off"))
            played_key = f"{owner}.{key}"
        keys = {tuple(tuple((c.kind, c.value, c.rule, c.entity, c.ref, c.point) for c in g) for g in ev.groups)
                for ev, _ in evs}
        spec = _spec(evs[0][0], ego, parsed) if len(keys) == 1 else None
        if spec is not None:
            sched = [(-1.0, init), *sorted((round(spec[1] + delay_of(ev), 4), st) for ev, st in evs)]
        else:
            sched = [(0.0, init)] + [(round(k * played.dt, 4), st) for k, st in played.signals.get(played_key, [])]
            if evs:
                notes.append(f"{actor.name}'s {key} changes start on different conditions, or on conditions not on "
                             "the ego alone: they happen at the times they happened in the file")
        actor.states[key] = sched
        if not evs or actor.cause is not None:  # a motion's cause state comes first
            continue
        actor.trigger = spec
        final = sched[-1][1]
        predicate = "light_is" if key == "light_state" else _STATE_PREDICATES.get((key, final))
        if predicate is None:
            continue
        actor.event, actor.condition = evs[0][0].name, condition_words(evs[0][0], ego)
        words = {"light_state": f"turns {final}", "door": "opens its door", "siren": "switches its siren on",
                 "hazard_lights": "switches its hazard lights on"}[key]
        actor.action = words
        actor.cause = AbstractState(name=f"shows_{final}" if key == "light_state" else predicate, actor=actor.name,
                                    cause=True, all_of=[PredicateCall(name=predicate, args=[actor.name],
                                                                      params={"value": final} if key == "light_state"
                                                                      else {})])
        thing = "traffic light" if key == "light_state" else actor.asset.replace("_", " ")
        texts.append(f"the {thing} {words} when {actor.condition}")
    return texts


def _recorded_ego(parsed: ParsedScenario, played: Played, ego: str, map_name: str, dt: float) -> RecordedEgo:
    poses = played.poses[ego]
    t = np.arange(len(poses)) * dt
    arr = np.array(poses, float)
    traj = Trajectory(t=t, x=arr[:, 0], y=arr[:, 1], heading=arr[:, 2], speed=arr[:, 3], source=parsed.path.name)
    det = detect(traj, map_name=map_name)
    if CLASSES[det.behavior][0] is None:
        raise ConfigError(f"{parsed.path}: the ego's story shows '{det.text}', which no ego template verifies; "
                          "regen import verifies a stop, a slow-down, a start, a lane change, a stop after a turn "
                          "or a stop in an intersection")
    return RecordedEgo(source=parsed.path.name, frame="map", map=map_name, detected=det.behavior,
                       event_time=round(det.event_time, 3), placement=f"the ego of {parsed.path.name}",
                       evidence=list(det.evidence), dt=dt, samples=_rounded(poses))


def _ego_fsm(t) -> FSM:
    """The ego's own stages: its start state, a turn before its reaction, its reaction."""
    (ename, ecalls), events = t.ego_states()
    states = [AbstractState(name=ename, actor="ego", all_of=ecalls)]
    stages = [Stage(conditions=[StateRef(actor="ego", state=ename)])]
    for name, calls in [*t.prelude(), *events]:
        states.append(AbstractState(name=name, actor="ego", all_of=calls))
        stages.append(Stage(conditions=[StateRef(actor="ego", state=name)]))
    return FSM(states=states, stages=stages)


__all__ = ["import_xosc"]
