"""The Scenic programs of a scenario as files other Scenic installs run: ``scenario.scenic`` for
Scenic's Newtonian model (what the embedded simulator runs) and ``scenario.carla.scenic`` for
Scenic's CARLA model (``scenic.simulators.carla.model``): the same actors, routes, triggers and
behaviors (they use the driving domain's own actions, which both models run), with the CARLA
blueprint of every asset from the asset database. Both name their map as the copy of the
``.xodr`` beside them (``localPath``, which Scenic resolves relative to the program's file), so
the scenario folder runs wherever it is copied to, and their docstring holds the command that
runs them once, in their folder (``scenic --2d --simulate --count 1 --time STEPS FILE``; without
``--count`` Scenic simulates again and again). The CARLA program compiles offline in 2D mode;
run it against a CARLA server with the map loaded from that file (docs/interop.md)."""

from __future__ import annotations

import re
from pathlib import Path

from regen.core.io import atomic_write_bytes, atomic_write_text
from regen.core.scenario import Scenario
from regen.driving.assets import database as driving_database
from regen.driving.grounding.rules import plans_for
from regen.driving.interop.openscenario import map_file_name
from regen.driving.simulation.program import write_program
from regen.driving.simulation.scenario import map_name, scenic_program, timing
from regen.driving.world.maps import ensure_map
from regen.errors import RegenError

EGO_BLUEPRINT = "vehicle.lincoln.mkz_2020"  # CARLA's usual ego car
PROGRAM = "scenario.scenic"
CARLA_PROGRAM = "scenario.carla.scenic"
#: the program's map line and its docstring's run command (program.scenic.j2)
_MAP_LINE = re.compile(r"^param map = .*$", re.M)
_RUN_LINE = re.compile(r"^Run: (scenic [^\n<]*)<this file>$", re.M)
RUN_PREFIX = "Run in this folder: "  # the docstring's line that holds the command


def carla_program(scenario: Scenario) -> str:
    """The program for Scenic's CARLA model (the map by file name, beside the program)."""
    _, plans = plans_for(scenario)
    dt, steps, seed = timing(scenario)
    db = driving_database()
    blueprints = {a: str(db.assets[a].blueprint) for a in {p.asset for p in plans}
                  if a in db.assets and getattr(db.assets[a], "blueprint", None)}
    blueprints["ego"] = EGO_BLUEPRINT
    return write_program(plans, map_path=str(ensure_map(map_name(scenario))), dt=dt, max_steps=steps,
                         narrative=scenario.narrative, seed=seed, title=scenario.behavior.text,
                         blueprints=blueprints)


def in_folder(program: str, file_name: str, map_file: str) -> str:
    """``program`` as the file ``file_name`` beside the map ``map_file``: its map found relative
    to the file (``localPath``), its run command naming the file."""
    text, n_map = _MAP_LINE.subn(lambda _: f"param map = localPath({map_file!r})", program, count=1)
    text, n_run = _RUN_LINE.subn(lambda m: f"{RUN_PREFIX}{m.group(1)}{file_name}", text, count=1)
    if (n_map, n_run) != (1, 1):
        raise RegenError("the Scenic program has no 'param map' line or no 'Run:' line to rewrite "
                         "(program.scenic.j2 changed?)")
    return text


def run_command(program: str) -> str:
    """The command a program written by :func:`export_scenic` documents (run in its folder)."""
    for line in program.splitlines():
        if line.startswith(RUN_PREFIX):
            return line[len(RUN_PREFIX):].strip()
    raise RegenError(f"the program documents no command (no line starting {RUN_PREFIX!r})")


def copy_map(scenario: Scenario, out_dir: Path) -> Path:
    """The scenario's ``.xodr`` beside the programs in ``out_dir`` (a copy already there is kept:
    the OpenSCENARIO export writes its own, with the lights' signals)."""
    source = ensure_map(map_name(scenario))
    target = Path(out_dir) / map_file_name(source)
    if not target.is_file():
        atomic_write_bytes(target, source.read_bytes())
    return target


def export_scenic(scenario: Scenario, out_dir: Path) -> dict[str, Path]:
    """``scenario.scenic`` (the program the embedded simulator runs) and ``scenario.carla.scenic``
    in ``out_dir``, with the map they run on beside them (``"xodr"``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    xodr = copy_map(scenario, out)
    return {"scenic": atomic_write_text(out / PROGRAM, in_folder(scenic_program(scenario), PROGRAM, xodr.name)),
            "carla_scenic": atomic_write_text(out / CARLA_PROGRAM,
                                              in_folder(carla_program(scenario), CARLA_PROGRAM, xodr.name)),
            "xodr": xodr}


__all__ = ["CARLA_PROGRAM", "PROGRAM", "RUN_PREFIX", "carla_program", "copy_map", "export_scenic", "in_folder",
           "run_command"]
