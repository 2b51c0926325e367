"""Read a run folder into plain view objects for the report, defensively.

The report must render whatever is on disk, including a run that crashed half-way or files a
user edited by hand: every reader returns ``None`` plus a short problem text instead of raising,
and the page then shows the item as missing or unreadable.
"""

from __future__ import annotations

import logging
import sqlite3
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from regen.contract import ANIMATION, KEYFRAMES, ReportHints
from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.scenario import Scenario
from regen.core.verdict import Causal, Verdict
from regen.report.links import href
from regen.runfolder import Loaded, RunFolder, ScenarioFolder, read_json, read_model, read_text

if TYPE_CHECKING:
    from regen.report.tests_view import BehaviorTests

log = logging.getLogger(__name__)

# Scenario files the page links to when they exist, in the order shown (then the domain's exports).
LINKED_FILES: tuple[str, ...] = (ScenarioFolder.SCENARIO, ScenarioFolder.VERDICT, ScenarioFolder.TRACE,
                                 ScenarioFolder.PATH, ScenarioFolder.TIMINGS, ScenarioFolder.ERROR)


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
    gif: str | None = None  # href of the domain's animation
    keyframes: str | None = None  # href of the domain's key frames
    keyframes_height: int | None = None  # [px] of the key-frame strip (its PNG header)

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
            return [e.asset for e in self.scenario.entities if not e.is_robot]
        if self.path is not None:
            return [e.asset for e in self.path.entities]
        return []

    @property
    def status(self) -> str:
        if self.verdict is not None:
            return self.verdict.status
        return "unfinished" if self.verdict_problem == "missing" else "unreadable"

    @property
    def title(self) -> str:
        """What the scenario is called in the gallery: its root cause (else its folder)."""
        chain = self.chain
        return chain[0] if len(chain) > 1 else self.folder

    @property
    def why(self) -> str:
        """One line of why it ended as it did: the verdict's reason, or what is missing."""
        if self.verdict is not None:
            return self.verdict.reason
        return f"verdict.json: {self.verdict_problem or 'missing'}"

    @property
    def relaxations(self) -> list[str]:
        """FSM stages relaxed during verification."""
        return list(self.verdict.relaxations) if self.verdict else []

    @property
    def placement_relaxations(self) -> list[str]:
        return _unique((self.scenario.solver.relaxations if self.scenario else [])
                       + (self.verdict.placement_relaxations if self.verdict else []))

    @property
    def fallbacks(self) -> list[str]:
        """Parts of the scenario that rules wrote where the model's answer was unusable."""
        return _unique((self.scenario.fallbacks if self.scenario else [])
                       + (self.verdict.fallbacks if self.verdict else []))

    @property
    def conflicts(self) -> list[str]:
        return _unique((self.scenario.solver.conflicts if self.scenario else [])
                       + (self.verdict.conflicts if self.verdict else []))


    @property
    def causal(self) -> Causal | None:
        """Whether the cause causes the behavior (None: not checked, e.g. an older verdict.json)."""
        return self.verdict.causal if self.verdict is not None else None

    @property
    def causal_label(self) -> str:
        """The causal part in words for the page ('caused', 'confounded by traffic_light1')."""
        return causal_label(self.causal)


def causal_text(causal: Causal | None) -> str | None:
    """The causal part of a verdict in a few words, beside its status: 'caused',
    'not_sufficient', 'confounded: traffic_light1' (its confounders appended). None when the
    verdict has no causal part (written before the check existed)."""
    if causal is None:
        return None
    return f"{causal.status}: {', '.join(causal.confounders)}" if causal.confounders else causal.status


def causal_label(causal: Causal | None) -> str:
    """The causal part for people to read: 'caused', 'confounded by traffic_light1', 'not
    sufficient', 'not checked' (also for a verdict without one)."""
    if causal is None:
        return "not checked"
    label = causal.status.replace("_", " ")
    if causal.confounders:
        label += (" by " if causal.status == "confounded" else ": ") + ", ".join(causal.confounders)
    return label


def _unique(items: list[str]) -> list[str]:
    return list(dict.fromkeys(items))


@dataclass
class Summary:
    total: int  # scenario folders
    finished: int  # with a readable verdict
    feasible: int
    statuses: dict[str, int]  # verdict status (or 'unfinished'/'unreadable') -> count
    relaxed: int = 0  # feasible only after relaxing the FSM
    fsm_sources: dict[str, int] = field(default_factory=dict)  # feasible scenarios by who wrote their FSM
    causal: dict[str, int] = field(default_factory=dict)  # causal status -> count (verdicts that have one)

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
    hints: ReportHints = field(default_factory=ReportHints)  # the domain's captions
    scenarios: list[ScenarioView] = field(default_factory=list)
    stray: list[str] = field(default_factory=list)  # run.json names with no usable folder
    tests: BehaviorTests | None = None  # regen test's results (RUN/tests/), None: none run
    whatifs: list[Any] = field(default_factory=list)  # regen whatif's counterfactuals (RUN/whatif/)
    falsify: list[Any] = field(default_factory=list)  # regen falsify's searches (RUN/falsify/)

    @property
    def summary(self) -> Summary:
        statuses = Counter(s.status for s in self.scenarios)
        finished = [s for s in self.scenarios if s.verdict is not None]
        return Summary(total=len(self.scenarios), finished=len(finished),
                       feasible=sum(1 for s in finished if s.verdict and s.verdict.feasible),
                       statuses=dict(sorted(statuses.items())),
                       relaxed=sum(1 for s in finished if s.verdict and s.verdict.relaxations
                                   and s.verdict.feasible),
                       fsm_sources=dict(Counter(s.scenario.fsm_source for s in finished
                                                if s.verdict and s.verdict.feasible and s.scenario)),
                       causal=dict(sorted(Counter(s.causal.status for s in finished
                                                  if s.causal is not None).items())))

    def run_field(self, key: str) -> Any:
        return self.run.get(key) if isinstance(self.run, dict) else None


def load_scenario(run: RunFolder, folder: str, number: int) -> ScenarioView:
    """Read one scenario folder; never raises for bad or missing files."""
    sf = run.scenario(folder)
    view = ScenarioView(number=number, folder=folder, anchor=f"scenario-{number}")
    sc = read_model(sf / sf.SCENARIO, Scenario, key="scenario")
    view.scenario, view.scenario_problem = sc.value, sc.problem
    raw = read_json(sf / sf.SCENARIO)
    if raw.ok and isinstance(raw.value, dict):
        view.config = raw.value.get("config")
    vd = read_model(sf / sf.VERDICT, Verdict)
    view.verdict, view.verdict_problem = vd.value, vd.problem
    if view.scenario is None:
        view.path = read_model(sf / sf.PATH, CausePath).value
    view.timings = sf.timings()
    err = read_text(sf / sf.ERROR)
    view.error_text = err.value if err.ok else None
    rel = (RunFolder.SCENARIOS, folder)
    view.files = {name: href(*rel, name) for name in LINKED_FILES if (sf / name).is_file()}
    roles = sf.files()  # what the domain's render/export wrote, by role
    if ANIMATION in roles:
        view.gif = href(*rel, roles[ANIMATION])
    if KEYFRAMES in roles:
        view.keyframes = href(*rel, roles[KEYFRAMES])
        view.keyframes_height = _png_height(sf / roles[KEYFRAMES])
    for role, name in roles.items():
        if role not in (ANIMATION, KEYFRAMES):
            view.files.setdefault(name, href(*rel, name))
    return view


def call_purposes(run_dir: Path, keys: list[str]) -> dict[str, str]:
    """The purpose of each model call (its cache key) the run's model cache records
    (``llm-cache.sqlite`` in the run folder), read only; {} when there is no such cache or it
    cannot be read (a run with ``--cache`` elsewhere)."""
    path = RunFolder(run_dir).cache_path
    if not keys or not path.is_file():
        return {}
    try:
        db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=1)
        try:
            marks = ",".join("?" * len(keys))
            rows = db.execute(f"SELECT key, purpose FROM calls WHERE key IN ({marks})", keys).fetchall()
        finally:
            db.close()
    except sqlite3.Error as exc:
        log.debug("model cache %s unreadable: %s", path, exc)
        return {}
    return {str(k): str(v) for k, v in rows}


def _png_height(path: Path) -> int | None:
    """[px] the height in a PNG file's header; None for a file that is not a readable PNG."""
    try:
        with open(path, "rb") as f:
            head = f.read(24)
    except OSError:
        return None
    if len(head) < 24 or not head.startswith(b"\x89PNG\r\n\x1a\n") or head[12:16] != b"IHDR":
        return None
    return int.from_bytes(head[20:24], "big") or None


def _hints(domain: str | None) -> ReportHints:
    from regen import domains
    from regen.errors import RegenError

    try:
        return domains.backend_class(domain).report_hints if domain else ReportHints()
    except (RegenError, ImportError):  # a run of a domain this installation lacks still shows
        return ReportHints()


def load_run(run_dir: Path, manifest: dict[str, Any] | None = None) -> RunView:
    """Read a run folder (see docs/run-folder.md) into a :class:`RunView`; never raises for
    missing or broken files inside it. ``manifest`` stands in for run.json (the pipeline
    passes the finished one: run.json says 'done' only after the report is written)."""
    run = RunFolder(run_dir)
    view = RunView(run_dir=run.path)
    raw = Loaded(manifest) if manifest is not None else run.read_manifest_raw()
    view.run, view.run_problem = raw.value, raw.problem
    graph = read_model(run / run.GRAPH, ScenarioGraph)
    view.graph, view.graph_problem = graph.value, graph.problem
    behavior = read_model(run / run.MANIFEST, Behavior, key="behavior")
    if manifest is not None and isinstance(manifest.get("behavior"), dict):
        behavior = Loaded(Behavior.model_validate(manifest["behavior"]))
    if behavior.ok:
        view.behavior = behavior.value
    elif view.graph is not None:  # the graph carries the behavior too
        view.behavior = view.graph.behavior
    else:
        view.behavior_problem = behavior.problem
    view.hints = _hints(view.behavior.domain if view.behavior else None)
    if (run / "graph.png").is_file():
        view.graph_png = href("graph.png")
    if (run / "graph.html").is_file():
        view.graph_html = href("graph.html")
    folders = run.scenario_names()
    listed = view.run_field("scenarios")
    view.stray = [str(n) for n in listed if str(n) not in folders] if isinstance(listed, list) else []
    view.scenarios = [load_scenario(run, f, i) for i, f in enumerate(folders, start=1)]
    if view.behavior is None:  # a folder of hand-written chains: its scenarios name the domain
        domain = next((sv.scenario.domain for sv in view.scenarios if sv.scenario is not None), None)
        view.hints = _hints(domain)
    from regen.report.tests_view import load_tests  # it reads this module's views

    view.tests = load_tests(run.path, view.scenarios, view.behavior.text if view.behavior else "")
    from regen.report.whatif_view import load_whatifs

    view.whatifs = load_whatifs(run.path, {s.folder: s.anchor for s in view.scenarios})
    from regen.report.falsify_view import load_falsify

    view.falsify = load_falsify(run.path, {s.folder: (s.anchor, s.number) for s in view.scenarios})
    return view
