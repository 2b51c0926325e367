"""Progress of a batch: one display for every behavior (``--log``: a live table in a terminal,
plain lines in a log or a pipe, quiet, or the events as JSON lines)."""

from __future__ import annotations

import time
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any

from rich.console import Console
from rich.live import Live
from rich.table import Table

from regen.progress import make_progress


@dataclass
class _Row:
    status: str = "pending"
    stage: str = ""
    total: int = 0
    done: int = 0
    feasible: int = 0


class _Tally:
    """What the events say so far, per behavior, with the model's totals."""

    def __init__(self) -> None:
        self.rows: dict[str, _Row] = {}
        self.calls = self.cached = self.tokens = 0
        self.start = time.perf_counter()

    def take(self, ev: dict[str, Any]) -> str | None:
        """Count ``ev``; a line worth printing on its own, or None."""
        kind, name = ev.get("event"), str(ev.get("behavior", ""))
        if kind == "batch":
            self.rows = {n: _Row() for n in ev.get("names", [])}
            return f"batch: {ev.get('total')} behavior(s), {ev.get('workers')} simulation worker(s)"
        if kind == "fill":  # --fill-coverage planned its runs: they join the table
            runs = [str(r) for r in ev.get("runs") or []]
            for r in runs:
                self.rows.setdefault(r, _Row())
            return (f"coverage fill: {len(runs)} run(s) added: {', '.join(runs)}" if runs
                    else "coverage fill: no run to add (no uncovered class has a cause that fits)")
        row = self.rows.setdefault(name, _Row()) if name else None
        if kind == "llm_call":
            self.calls += 1
            self.cached += bool(ev.get("cached"))
            self.tokens += int(ev.get("tokens", 0))
        elif row is None:
            return f"batch {ev.get('status')} in {ev.get('wall_seconds')} s" if kind == "batch_done" else None
        elif kind == "behavior_started":
            row.status = "running"
            return f"{name}: started"
        elif kind == "stage":
            row.stage = str(ev.get("stage"))
        elif kind == "paths":
            row.total = int(ev.get("total") or 0)
        elif kind == "scenario_done":
            row.done += 1
            row.feasible += bool(ev.get("feasible"))
            return f"{name}: scenario {row.done}/{row.total or '?'} {ev.get('name')}: {ev.get('status')}"
        elif kind == "behavior_done":
            row.status = str(ev.get("status"))
            extra = f" ({ev.get('message')})" if ev.get("message") else ""
            return f"{name}: {row.status}, {row.feasible}/{row.total} feasible{extra}"
        return None


class BatchPlainProgress:
    """One plain line per behavior started or ended and per scenario finished."""

    def __init__(self, console: Console):
        self.console, self.tally = console, _Tally()

    def on_event(self, ev: dict[str, Any]) -> None:
        line = self.tally.take(ev)
        if line:
            self.console.print(" ".join(line.split()), markup=False, highlight=False, soft_wrap=True)


class BatchRichProgress:
    """A live table: one row per behavior (status, stage, scenarios done, feasible), the model's
    calls and tokens, the time."""

    def __init__(self, console: Console):
        self.tally = _Tally()
        self.live = Live(self._render(), console=console, refresh_per_second=2, transient=False)

    def _render(self) -> Table:
        t = Table(title=f"batch: {time.perf_counter() - self.tally.start:.0f} s; model: {self.tally.calls} calls "
                        f"({self.tally.cached} cached), {self.tally.tokens} tokens", title_justify="left")
        for col in ("behavior", "status", "stage", "scenarios", "feasible"):
            t.add_column(col)
        for name, r in self.tally.rows.items():
            t.add_row(name, r.status, r.stage if r.status == "running" else "", f"{r.done}/{r.total or '?'}",
                      str(r.feasible))
        return t

    def on_event(self, ev: dict[str, Any]) -> None:
        self.tally.take(ev)
        self.live.update(self._render())


def make_batch_progress(mode: str, *, console: Console, out: Console) -> AbstractContextManager[Any]:
    """The sink of ``--log MODE`` for a batch (:func:`regen.progress.make_progress` with the
    batch's plain lines and live table)."""
    return make_progress(mode, console=console, out=out, plain=BatchPlainProgress, rich=BatchRichProgress)


__all__ = ["BatchPlainProgress", "BatchRichProgress", "make_batch_progress"]
