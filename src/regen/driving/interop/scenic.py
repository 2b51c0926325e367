"""The Scenic programs of a scenario as files other Scenic installs run: ``scenario.scenic`` for
Scenic's Newtonian model (what the embedded simulator runs) and ``scenario.carla.scenic`` for
Scenic's CARLA model (``scenic.simulators.carla.model``): the same actors, routes, triggers and
behaviors (they use the driving domain's own actions, which both models run), with the CARLA
blueprint of every asset from the asset database and the exported ``.xodr`` beside it as the
map. It compiles offline in 2D mode; run it against a CARLA server with the map loaded from that
file (docs/interop.md)."""

from __future__ import annotations

from pathlib import Path

from regen.core.io import atomic_write_text
from regen.core.scenario import Scenario
from regen.driving.assets import database as driving_database
from regen.driving.grounding.rules import plans_for
from regen.driving.simulation.program import write_program
from regen.driving.simulation.scenario import map_name, scenic_program, timing
from regen.driving.world.maps import ensure_map

EGO_BLUEPRINT = "vehicle.lincoln.mkz_2020"  # CARLA's usual ego car


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


def export_scenic(scenario: Scenario, out_dir: Path) -> dict[str, Path]:
    """``scenario.scenic`` (the program the embedded simulator runs) and ``scenario.carla.scenic``
    in ``out_dir``."""
    out = Path(out_dir)
    return {"scenic": atomic_write_text(out / "scenario.scenic", scenic_program(scenario)),
            "carla_scenic": atomic_write_text(out / "scenario.carla.scenic", carla_program(scenario))}


__all__ = ["carla_program", "export_scenic"]
