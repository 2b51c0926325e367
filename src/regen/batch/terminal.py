"""A finished batch in the terminal: one line per behavior, then where the report is."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from regen.batch.runner import BatchRecord
from regen.batch.summary import SUMMARY_FILE
from regen.pipeline.terminal import shown
from regen.runfolder import read_json


def print_batch(console: Console, record: BatchRecord, out_dir: Path) -> None:
    """Each behavior's status (with its message unless done, and the scenarios the batch lost),
    then the batch's status, wall time and report."""
    for b in record.behaviors:
        colour = {"done": "green", "failed": "red"}.get(b.status, "yellow")
        lost = f"; {len(b.failed_scenarios)} not simulated (worker died)" if b.failed_scenarios else ""
        console.print(f"[{colour}]{shown(b.status)}[/] {shown(b.folder)}{shown(lost)}"
                      + (f": {shown(b.message)}" if b.message and b.status != "done" else ""))
    _print_fill(console, out_dir)
    console.print(f"[bold]batch {shown(record.status)}[/] in {record.wall_seconds:.0f} s; report: "
                  f"{shown(str(out_dir / 'report.html'))}")


def _print_fill(console: Console, out_dir: Path) -> None:
    """What ``--fill-coverage`` added, per behavior (from summary.json; nothing without fill runs)."""
    got = read_json(out_dir / SUMMARY_FILE)
    fills = got.value.get("fill") if got.ok and isinstance(got.value, dict) else None
    for f in fills if isinstance(fills, list) else []:
        if not isinstance(f, dict):
            continue
        runs = f.get("runs") if isinstance(f.get("runs"), list) else []
        added = [str(a) for a in f.get("added") or []]
        console.print(f"fill {shown(str(f.get('folder', '')))}: {len(runs)} extra run(s), "
                      f"typology classes {len(f.get('before') or [])} -> {len(f.get('after') or [])}"
                      + (f", added: {shown('; '.join(added))}" if added else ", nothing added")
                      + (f" ({shown(str(f['problem']))})" if f.get("problem") else ""))


__all__ = ["print_batch"]
