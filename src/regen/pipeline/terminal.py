"""The terminal lines of a run's outcomes, shared by ``regen generate`` and ``regen import``.

Imports: rich and the pipeline's own outcome type only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from rich.markup import escape

if TYPE_CHECKING:
    from rich.console import Console

    from regen.pipeline.stages import ScenarioOutcome


def print_outcomes(console: Console, outcomes: Sequence[ScenarioOutcome], out_dir: Path, *,
                   indent: str = "  ") -> None:
    """One line per scenario (its folder, its verdict in colour, the reason), then the report's path."""
    for o in outcomes:
        mark = f"[green]{o.verdict.status}[/]" if o.verdict.feasible else f"[red]{o.verdict.status}[/]"
        console.print(f"{indent}{escape(o.folder)}: {mark}: {escape(o.verdict.reason)}")
    report = out_dir / "report.html"
    if report.exists():
        console.print(f"report: {report}")
