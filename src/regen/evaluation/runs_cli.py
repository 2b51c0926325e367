"""``regen runs list`` and ``regen runs show``: what the run folders under a folder hold.

Mounted by :mod:`regen.cli` (``runs_app.command("list")(runs_list)``).
"""

from __future__ import annotations

import typer
from rich.console import Console
from rich.table import Table

from regen.pipeline.terminal import shown

console = Console(soft_wrap=True)


def runs_list(root: str = typer.Argument(".", metavar="FOLDER", help="A run folder or a folder of runs")) -> None:
    """Run folders with their behavior, status and success."""
    from pathlib import Path

    from regen.errors import RunError
    from regen.evaluation.runs import causal_counts
    from regen.runfolder import RunFolder, list_runs, read_json

    base = Path(root)
    if not base.is_dir():
        raise RunError(f"{root} is not a folder: give a run folder or a folder of runs")
    table = Table(title=shown(f"runs under {root}"))
    for col in ("folder", "behavior", "domain", "status", "feasible", "caused", "started"):
        table.add_column(col, overflow="fold")  # wrapped, never cut: a cut path names no run
    for path, m, problem in list_runs(base):
        name = shown(path if path == base else path.relative_to(base))  # the title names the root
        if m is None:
            table.add_row(name, f"[yellow]run.json {shown(problem)}[/]", "", "?", "?", "", "")
            continue
        got = read_json(path / RunFolder.SUMMARY)
        if got.ok and isinstance(got.value, dict):
            feasible = shown(f"{got.value.get('feasible', '?')}/{got.value.get('scenarios', '?')}")
        elif got.problem == "missing":  # not finished yet
            feasible = "?"
        else:
            feasible = "[yellow]summary.json unreadable[/]"
        causal = causal_counts(path)  # scenarios whose cause causes the behavior / those checked
        caused = f"{causal.get('caused', 0)}/{sum(causal.values())}" if causal else "—"
        table.add_row(name, shown(m.behavior.text), shown(m.behavior.domain),
                      shown(m.status), feasible, caused, shown(m.started))
    console.print(table)


def runs_show(run: str = typer.Argument(..., metavar="RUN_DIR", help="A run folder made by regen generate")) -> None:
    """The scenarios of one run with their verdicts."""
    from pathlib import Path

    from regen.core.verdict import Verdict
    from regen.errors import RunError
    from regen.report.load import causal_text
    from regen.runfolder import RunFolder, read_model

    folder = RunFolder(Path(run))
    if not folder.is_run():
        raise RunError(f"{run} is not a run folder (no run.json): give the --out folder of "
                       f"'regen generate'; 'regen runs list {run}' lists the runs under a folder")
    m = folder.read_manifest()
    console.print(f"[bold]{shown(m.behavior.text)}[/] ({shown(m.behavior.domain)}), status "
                  f"{shown(m.status)}, started {shown(m.started)}")
    table = Table()
    for col in ("scenario", "verdict", "causal", "reason"):
        table.add_column(col)
    caused = checked = 0
    for name in folder.scenario_names():
        got = read_model(folder.scenario(name) / "verdict.json", Verdict)
        if got.ok:
            v = got.value
            status, reason, c = shown(v.status), shown(v.reason), v.causal  # causal: beside the status
            mark = "[dim]not checked[/]"
            if c is not None:
                checked, caused = checked + 1, caused + (c.status == "caused")
                colour = {"caused": "green", "not_checked": "dim"}.get(c.status, "yellow")
                mark = f"[{colour}]{shown(causal_text(c))}[/]"
                reason += f"\ncause: {shown(c.reason)}" if c.status != "caused" and c.reason else ""
            table.add_row(shown(name), f"[green]{status}[/]" if v.feasible else f"[red]{status}[/]",
                          mark, reason)
        elif got.problem == "missing":
            table.add_row(shown(name), "[yellow]not finished[/]", "", "")
        else:
            table.add_row(shown(name), "[yellow]verdict unreadable[/]", "", shown(got.problem))
    console.print(table)
    if checked:
        console.print(f"caused: {caused}/{checked} scenarios checked with a reference robot with and "
                      "without their cause")
