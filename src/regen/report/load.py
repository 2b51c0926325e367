"""Read a run folder into plain view objects for the report, defensively.

The report must render whatever is on disk, including a run that crashed half-way or files a
user edited by hand: every reader returns ``None`` plus a short problem text instead of raising,
and the page then shows the item as missing or unreadable.
"""

from __future__ import annotations

import json
import logging
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar
from urllib.parse import quote

from pydantic import BaseModel, ValidationError

from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.scenario import Scenario
from regen.core.verdict import Verdict

log = logging.getLogger(__name__)

M = TypeVar("M", bound=BaseModel)

MAX_TEXT_CHARS = 20_000  # error.txt beyond this is cut: a report page is not a log viewer
MAX_JSON_BYTES = 50_000_000  # larger files are not parsed (a trace can be big; the report skips it)
# Scenario files the page links to when they exist, in the order shown.
LINKED_FILES: tuple[str, ...] = ("scenario.scenic", "scenario.json", "scenario.xosc", "trace.json",
                                 "verdict.json", "path.json", "timings.json", "error.txt")
# A folder name from run.json is only trusted if it is one plain path component.
_SAFE_NAME = re.compile(r"^[^/\\\x00]+$")


@dataclass
class Loaded:
    """The outcome of reading one file: the value, or why there is none."""

    value: Any = None
    problem: str | None = None  # 'missing' or 'unreadable: ...'

    @property
    def ok(self) -> bool:
        return self.problem is None


def read_json(path: Path) -> Loaded:
    """Parse a JSON file; a missing, oversized or broken file gives a problem, not an exception."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            return Loaded(problem=f"unreadable: larger than {MAX_JSON_BYTES // 1_000_000} MB")
        return Loaded(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_model(path: Path, model: type[M], key: str | None = None) -> Loaded:
    """Read a JSON file (or its ``key`` member) as a pydantic model."""
    raw = read_json(path)
    if not raw.ok:
        return raw
    data = raw.value
    if key is not None:
        if not isinstance(data, dict) or key not in data:
            return Loaded(problem=f"unreadable: no {key!r} member")
        data = data[key]
    try:
        return Loaded(model.model_validate(data))
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ()))
        return Loaded(problem=f"unreadable: {where or 'value'}: {first.get('msg', 'invalid')}"
                              f" ({exc.error_count()} error(s))")
    except Exception as exc:  # model validators may raise domain errors (e.g. GraphCycleError)
        return Loaded(problem=f"unreadable: {_short(exc)}")


def read_text(path: Path, limit: int = MAX_TEXT_CHARS) -> Loaded:
    """Read a text file, cut to ``limit`` characters (a note says how much was left out)."""
    if not path.is_file():
        return Loaded(problem="missing")
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        return Loaded(problem=f"unreadable: {_short(exc)}")
    if len(text) > limit:
        text = text[:limit] + f"\n[... {len(text) - limit} more characters in the file]"
    return Loaded(text)


def _short(exc: BaseException, limit: int = 200) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    return msg if len(msg) <= limit else msg[:limit] + "..."


def href(*parts: str) -> str:
    """A relative URL to a file in the run folder (each part percent-encoded)."""
    return "/".join(quote(p) for p in parts)


@dataclass
class ScenarioView:
    """Everything the page shows about one scenario folder."""

    number: int  # 1-based, in run order
    folder: str  # folder name under scenarios/
    anchor: str  # HTML id of its section
    scenario: Scenario | None = None
    scenario_problem: str | None = None
    config: Any = None  # the paper-style config beside the scenario, as parsed JSON
    verdict: Verdict | None = None
    verdict_problem: str | None = None
    path: CausePath | None = None  # fallback for the cause chain when scenario.json is absent
    timings: dict[str, float] = field(default_factory=dict)
    error_text: str | None = None
    files: dict[str, str] = field(default_factory=dict)  # linked file name -> relative href
    xodr: list[tuple[str, str]] = field(default_factory=list)  # (file name, href) of map files
    gif: str | None = None  # href of bird_eye.gif
    keyframes: str | None = None  # href of keyframes.png

    @property
    def chain(self) -> list[str]:
        """Event labels, root cause first, behavior last."""
        if self.scenario is not None:
            return list(self.scenario.causal_graph)
        if self.path is not None:
            return list(self.path.events)
        return []

    @property
    def assets(self) -> list[str]:
        if self.scenario is not None:
            return [e.asset for e in self.scenario.entities if e.kind != "ego"]
        if self.path is not None:
            return [e.asset for e in self.path.entities]
        return []

    @property
    def status(self) -> str:
        if self.verdict is not None:
            return self.verdict.status
        return "unfinished" if self.verdict_problem == "missing" else "unreadable"

    @property
    def relaxations(self) -> list[str]:
        return _unique((self.scenario.solver.relaxations if self.scenario else [])
                       + (self.verdict.relaxations if self.verdict else []))

    @property
    def conflicts(self) -> list[str]:
        return _unique((self.scenario.solver.conflicts if self.scenario else [])
                       + (self.verdict.conflicts if self.verdict else []))


def _unique(items: list[str]) -> list[str]:
    return list(dict.fromkeys(items))


@dataclass
class Summary:
    total: int  # scenario folders
    finished: int  # with a readable verdict
    feasible: int
    statuses: dict[str, int]  # verdict status (or 'unfinished'/'unreadable') -> count

    @property
    def success_rate(self) -> float | None:
        """Feasible share of the finished scenarios (None when none finished)."""
        return self.feasible / self.finished if self.finished else None


@dataclass
class RunView:
    """Everything the page shows about a run folder."""

    run_dir: Path
    run: dict[str, Any] | None = None
    run_problem: str | None = None
    behavior: Behavior | None = None
    behavior_problem: str | None = None
    graph: ScenarioGraph | None = None
    graph_problem: str | None = None
    graph_png: str | None = None
    graph_html: str | None = None
    scenarios: list[ScenarioView] = field(default_factory=list)
    stray: list[str] = field(default_factory=list)  # run.json names with no usable folder

    @property
    def summary(self) -> Summary:
        statuses = Counter(s.status for s in self.scenarios)
        finished = [s for s in self.scenarios if s.verdict is not None]
        return Summary(total=len(self.scenarios), finished=len(finished),
                       feasible=sum(1 for s in finished if s.verdict and s.verdict.feasible),
                       statuses=dict(sorted(statuses.items())))

    def run_field(self, key: str) -> Any:
        return self.run.get(key) if isinstance(self.run, dict) else None


def _scenario_folders(run_dir: Path, listed: Any) -> tuple[list[str], list[str]]:
    """Folder names in run order: those run.json lists, then any others on disk (sorted)."""
    base = run_dir / "scenarios"
    try:
        on_disk = sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []
    except OSError as exc:
        log.warning("cannot list %s: %s", base, exc)
        on_disk = []
    order: list[str] = []
    stray: list[str] = []
    if isinstance(listed, list):
        for name in listed:
            name = str(name)
            if _SAFE_NAME.match(name) and name not in (".", "..") and name in on_disk:
                if name not in order:
                    order.append(name)
            else:
                stray.append(name)
    order += [n for n in on_disk if n not in order]
    return order, stray


def load_scenario(run_dir: Path, folder: str, number: int) -> ScenarioView:
    """Read one scenario folder; never raises for bad or missing files."""
    d = run_dir / "scenarios" / folder
    view = ScenarioView(number=number, folder=folder, anchor=f"scenario-{number}")
    sc = read_model(d / "scenario.json", Scenario, key="scenario")
    view.scenario, view.scenario_problem = sc.value, sc.problem
    raw = read_json(d / "scenario.json")
    if raw.ok and isinstance(raw.value, dict):
        view.config = raw.value.get("config")
    vd = read_model(d / "verdict.json", Verdict)
    view.verdict, view.verdict_problem = vd.value, vd.problem
    if view.scenario is None:
        view.path = read_model(d / "path.json", CausePath).value
    tm = read_json(d / "timings.json")
    if tm.ok and isinstance(tm.value, dict):
        view.timings = {str(k): float(v) for k, v in tm.value.items()
                        if isinstance(v, (int, float)) and not isinstance(v, bool)}
    err = read_text(d / "error.txt")
    view.error_text = err.value if err.ok else None
    rel = ("scenarios", folder)
    view.files = {name: href(*rel, name) for name in LINKED_FILES if (d / name).is_file()}
    view.xodr = [(p.name, href(*rel, p.name)) for p in sorted(d.glob("*.xodr")) if p.is_file()]
    # driving draws bird_eye.gif + keyframes.png; manipulation renders run.gif + strip.png
    gif = next((n for n in ("bird_eye.gif", "run.gif") if (d / n).is_file()), None)
    frames = next((n for n in ("keyframes.png", "strip.png") if (d / n).is_file()), None)
    if gif:
        view.gif = href(*rel, gif)
    if frames:
        view.keyframes = href(*rel, frames)
    return view


def load_run(run_dir: Path) -> RunView:
    """Read a run folder (see docs/run-folder.md) into a :class:`RunView`; never raises for
    missing or broken files inside it."""
    run_dir = Path(run_dir)
    view = RunView(run_dir=run_dir)
    run = read_json(run_dir / "run.json")
    if run.ok and not isinstance(run.value, dict):
        run = Loaded(problem="unreadable: not a JSON object")
    view.run, view.run_problem = run.value, run.problem
    graph = read_model(run_dir / "graph.json", ScenarioGraph)
    view.graph, view.graph_problem = graph.value, graph.problem
    behavior = read_model(run_dir / "run.json", Behavior, key="behavior")
    if behavior.ok:
        view.behavior = behavior.value
    elif view.graph is not None:  # the graph carries the behavior too
        view.behavior = view.graph.behavior
    else:
        view.behavior_problem = behavior.problem
    if (run_dir / "graph.png").is_file():
        view.graph_png = href("graph.png")
    if (run_dir / "graph.html").is_file():
        view.graph_html = href("graph.html")
    folders, view.stray = _scenario_folders(run_dir, view.run_field("scenarios"))
    view.scenarios = [load_scenario(run_dir, f, i) for i, f in enumerate(folders, start=1)]
    return view
