"""The Scenic program of a scenario as a file other Scenic installs run."""

from __future__ import annotations

from pathlib import Path

from regen.core.io import atomic_write_text
from regen.core.scenario import Scenario
from regen.driving.simulation.scenario import scenic_program


def export_scenic(scenario: Scenario, out_dir: Path) -> dict[str, Path]:
    """``scenario.scenic`` in ``out_dir``: the program the embedded simulator runs."""
    return {"scenic": atomic_write_text(Path(out_dir) / "scenario.scenic", scenic_program(scenario))}


__all__ = ["export_scenic"]
