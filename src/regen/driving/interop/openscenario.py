"""OpenSCENARIO 1.x export of a driving run, for replay in esmini, CARLA's ScenarioRunner & co.

Every actor of the trace becomes an entity (vehicle, pedestrian or misc object, with its size, its
mass and performance (:mod:`regen.driving.interop.physics`) and its scenario properties), is
teleported to its first recorded pose, and, if it moves (and its motion primitive is one that
OpenSCENARIO replays, ``Primitive.xosc_trajectory``), follows the recorded path as a timed
polyline trajectory (positions subsampled, times absolute from the start of the run). The
scenario's OpenDRIVE map is copied beside the ``.xosc`` and referenced by its file name, so the
folder can be moved as a whole.

Names come from a language model: entity names are restricted to ``[A-Za-z0-9_-]`` before they
reach the file, and free text (narrative, property values) is stripped of characters XML cannot
hold; ElementTree escapes quotes and angle brackets.
"""

from __future__ import annotations

import logging
import math
import re
import shutil
from functools import lru_cache
from pathlib import Path

import numpy as np

from regen.core.io import atomic_write_bytes
from regen.core.scenario import Scenario
from regen.core.trace import ActorTrack, Trace
from regen.driving.interop.appearance import APPEARANCE, appearance_action
from regen.driving.interop.physics import VEHICLE_CATEGORY, physics
from regen.driving.interop.signals import Light, with_signals
from regen.driving.interop.storyboard import as_recorded, fire_index, state_group, triggered_group
from regen.driving.world.plan import ActorPlan
from regen.driving.world.setting import DrivingWorld
from regen.driving.world.triggers import Spec
from regen.errors import ConfigError, DependencyNotInstalled, RegenError

log = logging.getLogger(__name__)

__all__ = ["export_openscenario", "map_file_name", "safe_name", "validate_xosc"]

OSC_MINOR = 2  # OpenSCENARIO 1.2: widely read (esmini, ScenarioRunner) and has vehicle roles
SAMPLE_DT = 0.1  # [s] between trajectory vertices: every simulation step (a player replays the run exactly)
MOVING = 0.2  # [m] an actor whose path is shorter than this gets no trajectory

_ROLE = {"ambulance": "ambulance", "police_car": "police", "fire_truck": "fire"}
_MISC_CATEGORY = {"barrier": "barrier", "traffic_light": "pole"}
_NAME_OK = re.compile(r"[^A-Za-z0-9_-]")
_XML_BAD = re.compile("[^\u0009\u000a\u000d\u0020-\ud7ff\ue000-\ufffd]")


def safe_name(name: str) -> str:
    """``name`` with every character outside ``[A-Za-z0-9_-]`` replaced by ``_`` (never empty)."""
    out = _NAME_OK.sub("_", name.strip())[:64]
    return out or "entity"


def _safe_text(text: str, limit: int = 1000) -> str:
    """Free text without the characters XML 1.0 cannot represent, shortened to ``limit``."""
    return _XML_BAD.sub("", text)[:limit]


def _xosc():
    try:
        from scenariogeneration import xosc
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled("scenariogeneration", "driving", "OpenSCENARIO export") from exc
    return xosc


def _unique_names(names: list[str]) -> dict[str, str]:
    """Original name -> file name, safe and unique (suffixes on clashes)."""
    out: dict[str, str] = {}
    used: set[str] = set()
    for name in names:
        base = safe_name(name)
        cand, k = base, 2
        while cand in used:
            cand, k = f"{base}_{k}", k + 1
        used.add(cand)
        out[name] = cand
        if cand != name:
            log.warning("entity name %r is written as %r in the OpenSCENARIO file", name, cand)
    return out


def _kind(asset: str, db) -> str | None:
    """'vehicle', 'pedestrian', 'misc', or None for things that are not placed (sensors)."""
    if asset == "ego":  # the robot under test is a car (not in the database of causes)
        return "vehicle"
    cat = db.category_of(asset) if db is not None else None
    spec = db.assets.get(asset) if db is not None else None
    # a static object with doors is a parked vehicle; simulators should show a car
    if cat == "vehicles" or (spec is not None and "door" in spec.properties):
        return "vehicle"
    if cat == "pedestrians":
        return "pedestrian"
    if cat == "sensors":
        return None
    return "misc"


def _size(track: ActorTrack, db) -> tuple[float, float, float]:
    """Length, width, height [m]: the trace's footprint, else the database's size, else 1 m."""
    spec = db.assets.get(track.asset) if db is not None else None
    length, width, height = tuple(spec.size) if spec is not None else (1.0, 1.0, 1.0)
    if track.length > 0 and track.width > 0:
        length, width = track.length, track.width
    return length, width, track.height if track.height > 0 else height


def _entity(xosc, name: str, track: ActorTrack, kind: str, db, props: dict[str, str], dt: float):
    length, width, height = _size(track, db)
    # positions in the trace are footprint centres, so the reference point is the box centre
    bbox = xosc.BoundingBox(width, length, height, 0.0, 0.0, height / 2)
    mass, v_max, a_max, d_max = physics(track.asset, kind, db, track, dt)
    if kind == "vehicle":
        category = getattr(xosc.VehicleCategory, VEHICLE_CATEGORY.get(track.asset, "car"))
        role = _ROLE.get(track.asset)
        wheel = 0.4 if track.asset in ("bicycle", "motorcycle") else 0.7  # [m] wheel diameter
        front = xosc.Axle(0.5, wheel, 0.85 * width, 0.3 * length, wheel / 2)
        rear = xosc.Axle(0.0, wheel, 0.85 * width, -0.3 * length, wheel / 2)
        obj = xosc.Vehicle(name, category, bbox, front, rear, max_speed=v_max, max_acceleration=a_max,
                           max_deceleration=d_max, mass=mass, role=getattr(xosc.Role, role) if role else None)
    elif kind == "pedestrian":
        obj = xosc.Pedestrian(name, mass, xosc.PedestrianCategory.pedestrian, bbox, model=safe_name(track.asset))
    else:
        category = getattr(xosc.MiscObjectCategory, _MISC_CATEGORY.get(track.asset, "obstacle"))
        obj = xosc.MiscObject(name, mass, category, bbox)
    if track.asset == "ego":  # how CARLA ScenarioRunner finds the ego among the vehicles
        obj.add_property("type", "ego_vehicle")
    obj.add_property("regen_asset", safe_name(track.asset))
    for key, value in props.items():
        obj.add_property(f"regen_{safe_name(key)}", _safe_text(str(value), 200))
    return obj


def _samples(times: np.ndarray, sample_dt: float) -> np.ndarray:
    """Step indices every ``sample_dt`` seconds, first and last step included."""
    picks = [0]
    for i in range(1, len(times)):
        if times[i] - times[picks[-1]] >= sample_dt - 1e-9:
            picks.append(i)
    if picks[-1] != len(times) - 1:
        picks.append(len(times) - 1)
    return np.asarray(picks)


def _headings(track: ActorTrack) -> np.ndarray:
    if track.heading:
        return np.asarray(track.heading, float)
    x, y = np.asarray(track.x, float), np.asarray(track.y, float)
    h = np.arctan2(np.diff(y, append=y[-1:]), np.diff(x, append=x[-1:]))
    if len(h) > 1:
        h[-1] = h[-2]
    return h


def _position(xosc, track: ActorTrack, heading: np.ndarray, i: int):
    z = float(track.z[i]) if track.z else 0.0
    h = float(heading[i]) % (2 * math.pi)  # OpenSCENARIO headings are ccw from +x too
    return xosc.WorldPosition(float(track.x[i]), float(track.y[i]), z, h)


def _trajectory_event(xosc, name: str, track: ActorTrack, heading: np.ndarray, times: np.ndarray,
                      sample_dt: float):
    idx = _samples(times, sample_dt)
    poly = xosc.Polyline([float(times[i] - times[0]) for i in idx],
                         [_position(xosc, track, heading, int(i)) for i in idx])
    traj = xosc.Trajectory(f"{name}_path", False)
    traj.add_shape(poly)
    # position mode with absolute timing: replay where and when the actor was, not a controller
    action = xosc.FollowTrajectoryAction(traj, xosc.FollowingMode.position,
                                         xosc.ReferenceContext.absolute, 1, 0)
    event = xosc.Event(f"{name}_replay", xosc.Priority.override)
    event.add_action(f"{name}_follow", action)
    event.add_trigger(xosc.ValueTrigger(f"{name}_start", 0, xosc.ConditionEdge.none,
                                        xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual)))
    maneuver = xosc.Maneuver(f"{name}_maneuver")
    maneuver.add_event(event)
    group = xosc.ManeuverGroup(f"{name}_group")
    group.add_actor(name)
    group.add_maneuver(maneuver)
    return group


def _standing(scenario: Scenario) -> set[str]:
    """Actors whose motion primitive OpenSCENARIO does not replay as a trajectory (they stand);
    the others, the ego included, get one when their recorded path is long enough."""
    from regen.driving.primitives import find

    out = set()
    for e in scenario.entities:
        spec = find(e.behavior) if not e.is_robot and e.behavior else None
        if spec is not None and not spec.xosc_trajectory:
            out.add(e.name)
    return out


def _map_file(scenario: Scenario, trace: Trace) -> Path | None:
    raw = trace.meta.get("map_path")
    if isinstance(raw, str) and raw and Path(raw).is_file():
        return Path(raw)
    name = trace.meta.get("map") or DrivingWorld.of(scenario).map
    if isinstance(name, str) and name:
        try:
            from regen.driving.world.maps import ensure_map

            return ensure_map(name)
        except (ImportError, RegenError) as exc:
            log.warning("no map for the OpenSCENARIO export (%s)", exc)
    return None


def _plans(scenario: Scenario) -> dict[str, ActorPlan]:
    """Actor -> its plan (empty when the scenario cannot be planned)."""
    try:
        from regen.driving.grounding.rules import plans_for

        _, plans = plans_for(scenario)
    except (RegenError, KeyError, ValueError) as exc:
        log.warning("scenario %s: no triggers for the OpenSCENARIO export (%s); actors replay on time", scenario.id, exc)
        return {}
    return {p.name: p for p in plans}


def _state_changes(xosc, plans: dict[str, ActorPlan], trace: Trace, names: dict[str, str],
                   signal_ids: dict[str, str], init, db) -> list[tuple[str, list, Spec | None]]:
    """Every actor's states that the standard has actions for (:mod:`.appearance`): the first
    into ``init``, the changes as (actor, [(t, label, action)], its trigger as recorded)."""
    out = []
    for orig, plan in plans.items():
        name = names.get(orig)
        if name is None or orig not in trace.actors:
            continue
        changes: list[tuple[float, str, object]] = []
        signal = signal_ids.get(name)
        if signal is not None and "light_state" in plan.states:
            sched = plan.states["light_state"]
            init.add_global_action(xosc.TrafficSignalStateAction(signal, str(sched[0][1])))
            changes += [(float(t), f"turns_{v}", xosc.TrafficSignalStateAction(signal, str(v))) for t, v in sched[1:]]
        if _kind(trace.actors[orig].asset, db) == "vehicle":
            for key in APPEARANCE:
                sched = plan.states.get(key)
                first = appearance_action(xosc, key, str(sched[0][1]), name) if sched else None
                if first is None:
                    continue
                init.add_user_defined_action(first)
                changes += [(float(t), f"{key}_{v}", a) for t, v in sched[1:]
                            if (a := appearance_action(xosc, key, str(v), name)) is not None]
        if changes:
            spec = plan.trigger.spec() if plan.trigger is not None else None
            spec = as_recorded(spec, trace, fire_index(spec, trace, orig)) if spec is not None else None
            out.append((orig, sorted(changes, key=lambda c: c[0]), spec))
    return out


def _lights(plans: dict[str, ActorPlan], trace: Trace, names: dict[str, str]) -> list[Light]:
    """The traffic lights of the scenario whose light state is scheduled, where they stand,
    facing the ego (a light of the scenario is the one the ego sees)."""
    ego = trace.actors.get("ego")
    facing = float(_headings(ego)[0]) + math.pi if ego is not None and ego.x else None
    out = []
    for name, p in plans.items():
        track = trace.actors.get(name)
        if "light_state" in p.states and track is not None and track.x and name in names:
            out.append(Light(name=names[name], x=float(track.x[0]), y=float(track.y[0]),
                             heading=p.heading if facing is None else facing))
    return out


def export_openscenario(scenario: Scenario, trace: Trace, out_dir: Path, *,
                        sample_dt: float = SAMPLE_DT, ego_story: bool = True) -> dict[str, Path]:
    """Write ``scenario.xosc`` (OpenSCENARIO 1.2) and a copy of the ``.xodr`` map into ``out_dir``.

    ``sample_dt`` [s] is the spacing of trajectory vertices. An actor whose cause action starts on
    a trigger gets a storyboard event started by the matching condition on the ego
    (:mod:`regen.driving.interop.storyboard`); the others replay their recorded path on
    simulation time. Every actor has a Story of its own (the ego's first).
    ``ego_story=False`` leaves out the ego's own story (its path and its state changes; the ego
    is still placed, in its first states), for a user who drives it with their own stack.
    Returns ``{"xosc": path}`` plus ``"xodr"`` when the map is known. A trace without steps raises :class:`ConfigError`.
    """
    if trace.steps == 0:
        raise ConfigError(f"scenario {scenario.id!r}: the trace has no steps; nothing to export")
    if not sample_dt > 0:
        raise ConfigError(f"sample_dt must be positive, got {sample_dt!r}")
    xosc = _xosc()
    db = _database()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}

    names = _unique_names(list(trace.actors))
    plans = _plans(scenario)
    triggers = {n: p.trigger.spec() for n, p in plans.items() if p.trigger is not None and p.kind != "sensor"}
    road, signal_ids = _road_network(xosc, scenario, trace, out_dir, _lights(plans, trace, names), files)
    actors = _Actors(xosc, scenario, trace, db, names, sample_dt, ego_story)
    for orig, changes, spec in _state_changes(xosc, plans, trace, names, signal_ids, actors.init, db):
        if orig != "ego" or ego_story:
            actors.story(names[orig]).append(state_group(xosc, names[orig], changes, spec, actors.ego))
    actors.add_all(triggers)
    board = _storyboard(xosc, actors, float(actors.times[-1] - actors.times[0]))
    description = _safe_text(f"ReGen scenario {scenario.id}: {scenario.narrative}")
    doc = xosc.Scenario(description, "regen", xosc.ParameterDeclarations(), actors.entities, board, road,
                        xosc.Catalog(), osc_minor_version=OSC_MINOR)
    text = _to_xml(doc)
    files["xosc"] = atomic_write_bytes(out_dir / "scenario.xosc", text)
    log.info("exported %s: %d entities, %d trajectories", files["xosc"], len(names), actors.moving)
    return {"xosc": files["xosc"], **({"xodr": files["xodr"]} if "xodr" in files else {})}


def map_file_name(xodr: Path) -> str:
    """The name of a map's copy beside the exported files (the ``.xosc`` and the Scenic programs
    refer to it by this name)."""
    return f"{safe_name(Path(xodr).stem)}.xodr"


def _database():
    """The driving asset database, or None (every actor is then exported as an object)."""
    try:
        from regen.driving.assets import database as driving_database

        return driving_database()
    except RegenError as exc:
        log.warning("driving asset database unavailable (%s); exporting every actor as an object", exc)
        return None


def _road_network(xosc, scenario: Scenario, trace: Trace, out_dir: Path, lights: list[Light],
                  files: dict[str, Path]) -> tuple[object, dict[str, str]]:
    """(the RoadNetwork, light name -> its signal's id): the scenario's map copied into ``out_dir``
    (``files["xodr"]``), with a signal per scheduled light; an empty network without a map."""
    xodr = _map_file(scenario, trace)
    if xodr is None:
        log.warning("scenario %s: no OpenDRIVE map known; the .xosc has an empty road network",
                    scenario.id)
        return xosc.RoadNetwork(), {}
    signal_ids: dict[str, str] = {}
    files["xodr"] = out_dir / map_file_name(xodr)
    if lights:  # the map's copy holds a signal per light, for the storyboard to switch
        text, signal_ids = with_signals(xodr.read_text(encoding="utf-8"), lights)
        atomic_write_bytes(files["xodr"], text.encode("utf-8"))
    elif files["xodr"].resolve() != xodr.resolve():
        shutil.copyfile(xodr, files["xodr"])
    return xosc.RoadNetwork(roadfile=files["xodr"].name), signal_ids


class _Actors:
    """The actors of the trace as the file's entities, their initial placement (``init``) and the
    maneuver groups of each one's Story (``stories``, by file name)."""

    def __init__(self, xosc, scenario: Scenario, trace: Trace, db, names: dict[str, str], sample_dt: float,
                 ego_story: bool) -> None:
        self.xosc, self.trace, self.db, self.names = xosc, trace, db, names
        self.sample_dt, self.ego_story = sample_dt, ego_story
        self.props = {e.name: e.properties for e in scenario.entities}
        self.standing = _standing(scenario)
        self.times = np.asarray(trace.times, float)
        self.ego = names.get("ego", "ego")  # the ego's name in the file
        self.entities = xosc.Entities()
        self.init = xosc.Init()
        self.stories: dict[str, list] = {}  # entity -> its maneuver groups: one Story per actor
        self.moving = 0  # actors that follow a trajectory

    def story(self, name: str) -> list:
        return self.stories.setdefault(name, [])

    def add_all(self, triggers: dict[str, Spec]) -> None:
        """Every placed actor of the trace: its entity, its start, and its path if it moves (on
        its trigger in ``triggers``, by actor, where it has one)."""
        for orig, track in self.trace.actors.items():
            kind = _kind(track.asset, self.db)
            if kind is None or not track.x:
                continue
            self.add(orig, track, kind, triggers.get(orig))

    def add(self, orig: str, track: ActorTrack, kind: str, spec: Spec | None) -> None:
        """One actor: its entity, its teleport to its first pose, and, if it moves (and its
        primitive is replayed, and it is not a left-out ego), its start speed and its path."""
        xosc, name = self.xosc, self.names[orig]
        self.entities.add_scenario_object(name, _entity(xosc, name, track, kind, self.db, self.props.get(orig, {}),
                                                        float(self.trace.dt)))
        heading = _headings(track)
        self.init.add_init_action(name, xosc.TeleportAction(_position(xosc, track, heading, 0)))
        x, y = np.asarray(track.x, float), np.asarray(track.y, float)
        if orig in self.standing or float(np.hypot(np.diff(x), np.diff(y)).sum()) < MOVING:
            return
        if orig == "ego" and not self.ego_story:
            return
        if track.speed and kind != "misc":
            self.init.add_init_action(name, xosc.AbsoluteSpeedAction(float(track.speed[0]), xosc.TransitionDynamics(
                xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0)))
        self.story(name).append(self._path(orig, name, track, heading, spec))
        self.moving += 1

    def _path(self, orig: str, name: str, track: ActorTrack, heading: np.ndarray, spec: Spec | None):
        """The maneuver group of a moving actor's path: started by its trigger where it fired in
        the trace, else on simulation time."""
        xosc, trace, times = self.xosc, self.trace, self.times
        k_fire = fire_index(spec, trace, orig) if spec is not None else None
        if spec is None or k_fire is None:
            return _trajectory_event(xosc, name, track, heading, times, self.sample_dt)
        x, y = np.asarray(track.x, float), np.asarray(track.y, float)
        idx = sorted(set(int(i) for i in _samples(times, self.sample_dt)) | {k_fire})
        where = idx.index(k_fire)
        before = float(np.hypot(np.diff(x[: k_fire + 1]), np.diff(y[: k_fire + 1])).sum())
        return triggered_group(xosc, name, [_position(xosc, track, heading, i) for i in idx], times[idx], where,
                               as_recorded(spec, trace, k_fire), self.ego, moves_before=before >= MOVING)


def _storyboard(xosc, actors: _Actors, duration: float):
    """The StoryBoard: the actors' initial placement, a Story per actor (the ego's first), and a
    stop at the end of the recording (``duration`` [s])."""
    stop = xosc.ValueTrigger("end_of_recording", 0, xosc.ConditionEdge.rising,
                             xosc.SimulationTimeCondition(duration, xosc.Rule.greaterThan),
                             triggeringpoint="stop")
    board = xosc.StoryBoard(actors.init, stop)
    for name in sorted(actors.stories, key=lambda n: n != actors.ego):  # the ego's own story first
        act = xosc.Act(f"{name}_act", xosc.ValueTrigger(f"{name}_act_start", 0, xosc.ConditionEdge.none,
                                                         xosc.SimulationTimeCondition(0, xosc.Rule.greaterOrEqual)))
        for group in actors.stories[name]:
            act.add_maneuver_group(group)
        story = xosc.Story(f"{name}_story")
        story.add_act(act)
        board.add_story(story)
    return board


def _to_xml(doc) -> bytes:
    """The document as UTF-8 bytes, pretty-printed (scenariogeneration writes only to paths)."""
    import xml.etree.ElementTree as ET

    root = doc.get_element()
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


@lru_cache(maxsize=4)
def _schema(minor: int):
    try:
        import scenariogeneration
        import xmlschema
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled(exc.name or "xmlschema", "driving", "OpenSCENARIO validation") from exc
    # scenariogeneration installs its schemas in a top-level 'schemas' folder beside the package
    folder = Path(scenariogeneration.__file__).resolve().parent.parent / "schemas"
    stem = "1_3_1" if minor == 3 else f"1_{minor}"
    path = folder / f"OpenSCENARIO_{stem}.xsd"
    if not path.is_file():
        raise DependencyNotInstalled("scenariogeneration", "driving",
                                     f"OpenSCENARIO validation (schema {path.name} not found)")
    return xmlschema.XMLSchema(str(path))


def validate_xosc(path: Path) -> list[str]:
    """Schema errors of an OpenSCENARIO 1.x file (empty when valid), using the schema that
    ``scenariogeneration`` bundles for the file's ``revMinor``."""
    import xml.etree.ElementTree as ET

    try:
        tree = ET.parse(path)
    except (ET.ParseError, OSError) as exc:
        return [f"{path}: not readable XML: {exc}"]
    header = tree.getroot().find("FileHeader")
    if header is None or header.get("revMajor") != "1":
        return [f"{path}: no OpenSCENARIO 1.x FileHeader"]
    try:
        minor = int(header.get("revMinor", ""))
    except ValueError:
        return [f"{path}: revMinor is not a number"]
    if not 0 <= minor <= 3:
        return [f"{path}: OpenSCENARIO 1.{minor} has no bundled schema"]
    return [f"{e.path}: {e.reason}" for e in _schema(minor).iter_errors(tree)]
