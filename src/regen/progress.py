"""Progress of the main job: a rich live display in a terminal, plain lines in a log or a pipe,
quiet, or JSON lines for scripts."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.live import Live
from rich.table import Table


class _Sink:
    def on_event(self, ev: dict[str, Any]) -> None:  # pragma: no cover - interface
        pass


class QuietProgress(_Sink):
    pass


class JsonLinesProgress(_Sink):
    def __init__(self, out: Console):
        self.out = out

    def on_event(self, ev: dict[str, Any]) -> None:
        self.out.file.write(json.dumps(ev, default=str) + "\n")
        self.out.file.flush()


class PlainProgress(_Sink):
    """Progress where no live display can be drawn (a CI log, a pipe, a dumb terminal): one plain
    line per stage and per finished scenario, and in between a line on what is going on at most
    every ``every`` seconds; nothing is redrawn, nothing runs into the lines that follow."""

    def __init__(self, console: Console, *, every: float = 5.0, clock: Any = time.monotonic):
        self.console, self.every, self.clock = console, every, clock
        self.start = self.last = clock()
        self.stage = "starting"
        self.total = self.done = self.feasible = 0
        self.calls = self.cached = self.tokens = 0
        self.current = ""

    def _say(self, line: str) -> None:
        self.console.print(" ".join(line.split()), markup=False, highlight=False, soft_wrap=True)
        self.last = self.clock()

    def on_event(self, ev: dict[str, Any]) -> None:
        kind = ev.get("event")
        if kind == "stage":
            self.stage, self.current = str(ev.get("stage")), ""
            self._say(f"stage: {self.stage}")
            return
        if kind == "paths":
            self.total = int(ev.get("total") or 0)
            self._say(f"{self.total} {ev.get('what') or 'scenario(s) to ground and simulate'}")
            return
        if kind == "scenario_done":
            self.done += 1
            self.feasible += bool(ev.get("feasible"))
            kept = " (kept from an earlier run)" if ev.get("skipped") else ""
            self._say(f"scenario {self.done}/{self.total or '?'} done: {ev.get('name')}: {ev.get('status')}{kept}")
            return
        if kind == "llm_call":
            self.calls += 1
            self.cached += bool(ev.get("cached"))
            self.tokens += int(ev.get("tokens", 0))
        elif kind in ("grounding", "simulating", "redrawing", "drawing"):
            self.current = f"{kind} {ev.get('name')}"
        if self.clock() - self.last >= self.every:
            self._say(f"... {self.stage}{': ' + self.current if self.current else ''}; model: {self.calls} calls, "
                      f"{self.cached} cached, {self.tokens} tokens; {self.clock() - self.start:.0f} s elapsed")


class RichProgress(_Sink):
    """Stage, scenarios done/total, model calls, tokens, cache hits, elapsed and ETA."""

    def __init__(self, console: Console):
        self.console = console
        self.start = time.perf_counter()
        self.stage = "starting"
        self.total = 0
        self.done = 0
        self.feasible = 0
        self.calls = 0
        self.cached = 0
        self.tokens = 0
        self.current = ""
        self.kept = "feasible"  # what a done scenario that counts is (a 'paths' event's 'kept')
        self.scenario_started: float | None = None
        self.durations: list[float] = []
        self.live = Live(self._render(), console=console, refresh_per_second=4, transient=False)

    def _render(self) -> Table:
        elapsed = time.perf_counter() - self.start
        eta = "?"
        left = self.total - self.done
        if self.durations and left > 0:
            eta = f"{left * (sum(self.durations) / len(self.durations)):.0f} s"
        elif self.total and left == 0:
            eta = "0 s"
        t = Table.grid(padding=(0, 2))
        t.add_row("[bold]stage[/]", self.stage + (f" ({self.current})" if self.current else ""))
        t.add_row("[bold]scenarios[/]", f"{self.done}/{self.total or '?'} done, {self.feasible} {self.kept}")
        t.add_row("[bold]model[/]", f"{self.calls} calls, {self.cached} cached, {self.tokens} tokens")
        t.add_row("[bold]time[/]", f"{elapsed:.0f} s elapsed, ETA {eta}")
        return t

    def on_event(self, ev: dict[str, Any]) -> None:
        kind = ev["event"]
        if kind == "stage":
            self.stage = ev["stage"]
            self.current = ""
        elif kind == "llm_call":
            self.calls += 1
            self.cached += bool(ev.get("cached"))
            self.tokens += int(ev.get("tokens", 0))
        elif kind == "paths":
            self.total = ev["total"]
            self.kept = ev.get("kept") or self.kept
        elif kind in ("grounding", "simulating", "drawing"):
            self.current = ev["name"]
            self.scenario_started = time.perf_counter()
        elif kind == "scenario_done":
            self.done += 1
            self.feasible += bool(ev.get("feasible"))
            if self.scenario_started is not None and not ev.get("skipped"):
                self.durations.append(time.perf_counter() - self.scenario_started)
        self.live.update(self._render())


@contextmanager
def make_progress(mode: str, *, console: Console, out: Console, plain: Any = PlainProgress,
                  rich: Any = RichProgress) -> Iterator[Any]:
    """The sink of ``--log MODE``: 'quiet', 'jsonl' (events on ``out``), else 'rich': a live
    display on ``console`` when it is a terminal (``rich``, a sink with a ``live``), plain lines
    (``plain``) when not. A batch gives its own two (:mod:`regen.batch.progress`)."""
    if mode == "quiet":
        yield QuietProgress()
    elif mode == "jsonl":
        yield JsonLinesProgress(out)
    elif not console.is_terminal or console.is_dumb_terminal:
        yield plain(console)
    else:
        sink = rich(console)
        with sink.live:
            yield sink
