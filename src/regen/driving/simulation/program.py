"""Write a driving scenario as a Scenic program (Newtonian driving model, 2D, render off).

Nothing a model or user wrote reaches the program as code: actor names are whitelisted into
identifiers, numbers are formatted from floats, trigger kinds are checked against
:data:`regen.driving.world.triggers.KINDS`, the trigger functions are this package's own source
(:func:`regen.driving.world.triggers.scenic_source`), and free text (the narrative) is written as a
Python string literal (``repr``), with lone surrogates replaced first: a JSON escape would split
an emoji into two lone surrogates inside the program.
"""

from __future__ import annotations

import math
import re

import jinja2

from regen.driving.world.plan import ActorPlan, LaneChange
from regen.driving.world.sensing import scenic_source as sensing_source
from regen.driving.world.triggers import KINDS, Trigger, scenic_source
from regen.errors import ConfigError
from regen.templates import environment

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")
_SCENIC_CLASSES = {"Car", "Pedestrian", "Object"}
_SCENIC_BEHAVIORS = {"", "FollowRoute", "WalkRoute", "ReplayPath"}  # those program.scenic.j2 defines


def scenic_identifier(name: str) -> str:
    """The Scenic variable for an actor name ('ego' stays 'ego'); other names are prefixed."""
    if name == "ego":
        return "ego"
    cleaned = re.sub(r"[^A-Za-z0-9_]", "_", name)
    ident = f"a_{cleaned}"
    if not _IDENT.match(ident):
        raise ConfigError(f"actor name {name!r} cannot be written as a Scenic identifier; use "
                          "letters, digits and underscores (at most 60 characters)")
    return ident


def _literal(text: str) -> str:
    """``text`` as one safe string literal of the program (quotes and controls escaped)."""
    whole = text.encode("utf-16", "surrogatepass").decode("utf-16", "replace")  # pairs joined, lone ones replaced
    return repr(whole)


def _num(v: float) -> str:
    v = float(v)
    if not math.isfinite(v):
        raise ConfigError(f"a non-finite number ({v}) cannot be written into a Scenic program")
    return repr(round(v, 4))


def _points(route: list[tuple[float, float]]) -> str:
    return "[" + ", ".join(f"({_num(x)}, {_num(y)})" for x, y in route) + "]"


def _schedule(schedule: list[tuple[float, float, float]]) -> str:
    return "[" + ", ".join(f"({_num(t)}, {_num(s)}, {_num(b)})" for t, s, b in schedule) + "]"


def _poses(replay: list[tuple[float, float, float, float]]) -> str:
    """Replayed poses in Scenic's terms: (x, y, heading from +y [rad], speed)."""
    return "[" + ", ".join(f"({_num(x)}, {_num(y)}, {_num(h - math.pi / 2)}, {_num(v)})"
                           for x, y, h, v in replay) + "]"


def _relative_poses(poses: list[tuple[float, float, float, float]]) -> str:
    """Poses relative to where an actor is (ahead, left [m], turn [rad], speed): as they are."""
    return "[" + ", ".join(f"({_num(a)}, {_num(b)}, {_num(c)}, {_num(v)})" for a, b, c, v in poses) + "]"


def _trigger(trigger: Trigger | None) -> str:
    if trigger is None:
        return "None"
    if trigger.kind not in KINDS:
        raise ConfigError(f"unknown trigger kind {trigger.kind!r}; choose one of: {', '.join(KINDS)}")
    kind, *numbers = trigger.spec()
    return "(" + ", ".join([repr(kind)] + [_num(v) for v in numbers]) + ")"


def _sensing(sensing: tuple | None) -> str:
    """The ego's sensing spec (regen.driving.world.sensing.sensing_spec) as program text."""
    if sensing is None:
        return "None"
    spec, *numbers = sensing
    if spec is None:
        trigger = "None"
    else:
        if spec[0] not in KINDS:
            raise ConfigError(f"unknown trigger kind {spec[0]!r}; choose one of: {', '.join(KINDS)}")
        trigger = "(" + ", ".join([repr(spec[0])] + [_num(v) for v in spec[1:]]) + ")"
    return "(" + ", ".join([trigger] + [_num(v) for v in numbers]) + ")"


def _lane_change(lane_change: LaneChange | None) -> str:
    if lane_change is None:
        return "None"
    return "(" + ", ".join(_num(v) for v in lane_change.spec()) + ")"


def _template() -> jinja2.Template:
    """``program.scenic.j2`` beside this module: plain text, its last newline kept."""
    return environment("regen.driving.simulation", ".", keep_trailing_newline=True).get_template(
        "program.scenic.j2")


def write_program(plans: list[ActorPlan], *, map_path: str, dt: float, max_steps: int,
                  narrative: str = "", seed: int = 0, title: str = "regen scenario",
                  blueprints: dict[str, str] | None = None) -> str:
    """The Scenic program text for ``plans`` (the ego first) on the map at ``map_path``.

    ``dt`` is the step [s]; ``max_steps`` the number of steps the scenario is meant to run.
    Sensors (``cls == ''``) are not Scenic objects and are left out. ``blueprints`` (asset ->
    CARLA blueprint id): the same program for Scenic's CARLA model instead of its Newtonian one
    (the map by file name, ``carla_map`` its stem; the behaviors use the driving domain's own
    actions, which both models run).
    """
    actors = []
    seen: set[str] = set()
    ordered = sorted(plans, key=lambda p: p.name != "ego")  # Scenic wants the ego first
    if not ordered or ordered[0].name != "ego":
        raise ConfigError("a driving scenario needs an actor named 'ego'")
    for p in ordered:
        if not p.cls:
            continue
        if p.cls not in _SCENIC_CLASSES:
            raise ConfigError(f"actor {p.name!r}: unknown Scenic class {p.cls!r}")
        if p.scenic_behavior not in _SCENIC_BEHAVIORS:
            raise ConfigError(f"actor {p.name!r}: unknown Scenic behavior {p.scenic_behavior!r}")
        if p.lane_change is not None and p.trigger is None:
            raise ConfigError(f"actor {p.name!r}: a lane change is laid out when a trigger fires; it has none")
        var = scenic_identifier(p.name)
        if var in seen:
            raise ConfigError(f"two actors map to the Scenic identifier {var!r}; rename one")
        seen.add(var)
        # Scenic measures headings from +y; the plan measures them from +x
        scenic_heading = math.degrees(p.heading) - 90.0
        behavior = p.scenic_behavior if p.dynamic else ""
        actors.append({
            "var": var,
            "cls": p.cls,
            "name": _literal(p.name),
            "comment": " ".join(f"{p.name}: {p.asset}. {p.comment}".split())[:200],
            "x": _num(p.x), "y": _num(p.y), "heading": _num(scenic_heading),
            "length": _num(max(p.length, 0.1)), "width": _num(max(p.width, 0.1)),
            "speed": p.speed0 > 0 and p.cls == "Car",
            "vx": _num(p.speed0 * math.cos(p.heading)), "vy": _num(p.speed0 * math.sin(p.heading)),
            "behavior": behavior,
            # a lane-changing car follows its lane until its trigger lays the change out
            "route": _points(p.lane_change.lane_line(p.x, p.y) if p.lane_change else p.route)
            if behavior else "",
            "schedule": _schedule(p.schedule) if behavior else "",
            "trigger": _trigger(p.trigger) if behavior else "",
            "lane_change": _lane_change(p.lane_change),
            "poses": _poses(p.replay) if behavior == "ReplayPath" else "",
            "after": ("" if behavior != "ReplayPath" or not p.after else
                      _relative_poses(p.after) if p.after_relative else _poses(p.after)),
            "relative": "True" if p.after_relative else "False",
            "blueprint": _literal(blueprints[p.asset]) if blueprints and blueprints.get(p.asset) else "",
            "sensing": _sensing(p.sensing) if behavior == "FollowRoute" else "None",
        })
    return _template().render(
        title=" ".join(re.sub(r"[^A-Za-z0-9 _.,:;()-]", " ", title).split())[:200],
        # CARLA's program sits beside its copy of the map: found relative to the program file
        map_path=(f"localPath({_literal(str(map_path).rsplit('/', 1)[-1])})" if blueprints is not None
                  else _literal(str(map_path))),
        narrative=_literal(" ".join(narrative.split())),
        seed=int(seed), dt=_num(dt), max_steps=int(max_steps), actors=actors,
        trigger_source=scenic_source() + "\n\n\n" + sensing_source(),
        carla=blueprints is not None, carla_map=_literal(re.sub(r"\.xodr$", "", str(map_path).rsplit("/", 1)[-1])),
    )
