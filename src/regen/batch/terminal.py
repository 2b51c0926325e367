"""A finished batch in the terminal: one line per behavior, then where the report is."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from regen.batch.runner import BatchRecord
from regen.pipeline.terminal import shown


def print_batch(console: Console, record: BatchRecord, out_dir: Path) -> None:
    """Each behavior's status (with its message unless done, and the scenarios the batch lost),
    then the batch's status, wall time and report."""
    for b in record.behaviors:
        colour = {"done": "green", "failed": "red"}.get(b.status, "yellow")
        lost = f"; {len(b.failed_scenarios)} not simulated (worker died)" if b.failed_scenarios else ""
        console.print(f"[{colour}]{shown(b.status)}[/] {shown(b.folder)}{shown(lost)}"
                      + (f": {shown(b.message)}" if b.message and b.status != "done" else ""))
    console.print(f"[bold]batch {shown(record.status)}[/] in {record.wall_seconds:.0f} s; report: "
                  f"{shown(str(out_dir / 'report.html'))}")


__all__ = ["print_batch"]
