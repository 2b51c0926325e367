"""What a batch made: ``DIR/summary.json`` (:func:`summarize_batch`) and ``DIR/report.html``
(:func:`write_batch_report`), read from ``DIR/batch.json`` and each behavior's run folder.

Everything is read defensively, as the run report does: a batch still running, a behavior that
failed or never started, a run folder without ``summary.json`` all give a summary of what is on
disk plus, per behavior, what is missing in words. Counts come from the scenarios' own
``verdict.json`` files (the run's ``summary.json`` is only written when the run ends), stage
times and model usage from ``run.json``, policy results from ``tests/<policy>/tests.json``
(``regen test``). Diversity is the paper's (:mod:`regen.evaluation.diversity`) over the texts
of every feasible scenario of the batch; a metric whose optional package is missing is skipped
with the reason, never an error.

The page is rendered like the run report: Jinja2 with autoescaping, every ``{{ }}`` cleaned of
control characters, the report's stylesheet inlined, links relative to the batch folder.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import Field

from regen.batch.diversity import METRICS, Diversity, Encoder, batch_diversity
from regen.batch.fill import FillSummary, fill_summary
from regen.core.base import Model
from regen.core.io import atomic_write_text, write_json
from regen.core.verdict import FEASIBLE_STATUSES
from regen.errors import ConfigError
from regen.evaluation.runs import RunRecord, load_run
from regen.report.html import clean_text, fmt_percent, fmt_seconds, fmt_time, fmt_value
from regen.report.links import href
from regen.report.tests_view import load_tests
from regen.runfolder import RunFolder, merge_usage, read_json
from regen.templates import environment

log = logging.getLogger(__name__)

__all__ = ["BATCH_FILE", "BatchSummary", "BehaviorSummary", "summarize", "summarize_batch", "write_batch_report"]

BATCH_FILE = "batch.json"  # written by the runner
SUMMARY_FILE = "summary.json"
REPORT_FILE = "report.html"
#: run.json's stages in the order they run; others follow in the order first seen
STAGE_ORDER = ("expand", "ground", "simulate", "render", "report")
#: the bar's order: what played out first, then what was simulated but fell short, then
#: what could not be judged, then what the batch lost or has not done yet
BAR_ORDER = (*FEASIBLE_STATUSES, "unfaithful", "cause_not_shown", "fsm_incomplete", "unsatisfiable",
             "ungroundable", "invalid_scenario", "grounding_failed", "simulation_failed")
USAGE_KEYS = ("calls", "model_calls", "cache_hits", "input_tokens", "output_tokens", "latency")


class PolicyTests(Model):
    """One policy's ``regen test`` results in a behavior's run folder."""

    folder: str  # under RUN/tests/
    policy: str
    tests: int = 0  # cases that ran
    passed: int = 0
    failed: int = 0
    collisions: int = 0
    collision_rate: float | None = None  # collisions / tests; None: none ran
    problem: str | None = None  # tests.json could not be read (wholly or partly)


class FailedScenario(Model):
    folder: str  # scenario folder name
    reason: str


class BehaviorSummary(Model):
    """One behavior of the batch: its run folder's state and counts."""

    number: int  # 1-based, in the spec's order
    folder: str  # the run folder's name in the batch folder
    text: str = ""
    domain: str = ""
    status: str = "unknown"  # the batch's: pending, running, done, failed
    message: str = ""  # why the batch marked it failed
    run_status: str | None = None  # run.json's status; None: no run.json yet
    report: str | None = None  # relative link to its report.html, when there is one
    requested: int | None = None  # scenarios asked for (-n)
    scenario_folders: int = 0  # scenario folders on disk
    finished: int = 0  # with a readable verdict
    not_started: int = 0  # requested scenarios with no folder yet (a behavior not done)
    unfinished: list[str] = Field(default_factory=list)  # folders without a verdict (not failed)
    statuses: dict[str, int] = Field(default_factory=dict)  # verdict status -> count
    verified: int = 0  # status 'verified'
    feasible: int = 0  # verified, or verified after relaxation
    caused: int = 0  # feasible and the causal check says 'caused'
    causal: dict[str, int] = Field(default_factory=dict)  # causal status -> count
    failed_scenarios: list[FailedScenario] = Field(default_factory=list)  # lost by the batch
    lost: int = 0  # failed scenarios that have no verdict (a later retry may have made one)
    timings: dict[str, float] = Field(default_factory=dict)  # stage -> wall seconds (run.json)
    wall_seconds: float | None = None  # [s] as the batch measured it
    usage: dict[str, int | float] = Field(default_factory=dict)  # model usage totals (run.json)
    tests: list[PolicyTests] = Field(default_factory=list)  # empty: no policy tests ran
    missing: list[str] = Field(default_factory=list)  # what is not on disk (yet), in words
    #: a ``--fill-coverage`` run: the spec behavior's folder it fills, its cause, the typology
    #: classes (ids) it aims at; None for a spec entry
    fill_of: str | None = None
    fill_cause: str | None = None
    fill_classes: list[str] = Field(default_factory=list)


class Totals(Model):
    behaviors: int = 0
    by_status: dict[str, int] = Field(default_factory=dict)  # batch status -> behaviors
    requested: int = 0
    scenario_folders: int = 0
    finished: int = 0
    statuses: dict[str, int] = Field(default_factory=dict)
    verified: int = 0
    feasible: int = 0
    caused: int = 0
    causal: dict[str, int] = Field(default_factory=dict)
    failed_scenarios: int = 0
    timings: dict[str, float] = Field(default_factory=dict)
    usage: dict[str, int | float] = Field(default_factory=dict)
    tests: int = 0  # policy tests that ran, over all behaviors and policies
    collisions: int = 0


class BatchSummary(Model):
    """``DIR/summary.json``."""

    version: int = 1
    spec_file: str = ""
    executor: str = ""  # pool or ray
    workers: int | None = None
    ray_address: str | None = None
    status: str = "unknown"  # the batch's: running, done, interrupted, failed
    message: str = ""
    started: str | None = None
    finished: str | None = None
    wall_seconds: float | None = None
    problems: list[str] = Field(default_factory=list)  # batch.json missing or unreadable, ...
    behaviors: list[BehaviorSummary] = Field(default_factory=list)
    totals: Totals = Field(default_factory=Totals)
    diversity: Diversity = Field(default_factory=Diversity)
    #: ``--fill-coverage``: per spec behavior with fill runs, the typology classes covered
    #: before and after, and what each fill run showed
    fill: list[FillSummary] = Field(default_factory=list)


# --- reading ---------------------------------------------------------------------------------


def _str(value: Any, default: str = "") -> str:
    return value if isinstance(value, str) else default


def _num(value: Any) -> float | None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    return float(value) if ok else None


def _count(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


def _is_child(name: str) -> bool:
    """A plain folder name (a hand-edited batch.json must not point outside the batch)."""
    return bool(name) and name not in (".", "..") and "/" not in name and "\\" not in name


def _read_batch(batch_dir: Path, out: BatchSummary) -> list[dict[str, Any]]:
    """Fill the batch-wide fields of ``out`` from batch.json; return its behavior entries (or,
    without a readable batch.json, one per run folder found in the batch folder)."""
    got = read_json(batch_dir / BATCH_FILE)
    data = got.value if got.ok and isinstance(got.value, dict) else None
    if data is None:
        out.problems.append(f"{BATCH_FILE}: {got.problem or 'unreadable: not a JSON object'}")
        found = sorted(p.name for p in batch_dir.iterdir() if (p / RunFolder.MANIFEST).is_file())
        return [{"folder": name} for name in found]
    out.spec_file, out.executor = _str(data.get("spec_file")), _str(data.get("executor"))
    out.workers, out.ray_address = _count(data.get("workers")), _str(data.get("ray_address")) or None
    out.status, out.message = _str(data.get("status"), "unknown"), _str(data.get("message"))
    out.started, out.finished = _str(data.get("started")) or None, _str(data.get("finished")) or None
    out.wall_seconds = _num(data.get("wall_seconds"))
    entries = data.get("behaviors")
    if not isinstance(entries, list):
        out.problems.append(f"{BATCH_FILE}: no list of behaviors")
        return []
    usable = [e for e in entries if isinstance(e, dict) and _is_child(_str(e.get("folder")))]
    if len(usable) < len(entries):
        out.problems.append(f"{BATCH_FILE}: {len(entries) - len(usable)} behavior entr(ies) without "
                            "a usable folder name, left out")
    return usable


def _from_entry(number: int, entry: dict[str, Any]) -> BehaviorSummary:
    """What batch.json says of one behavior."""
    failed = entry.get("failed_scenarios")
    return BehaviorSummary(
        number=number, folder=entry["folder"], text=_str(entry.get("text")),
        domain=_str(entry.get("domain")), status=_str(entry.get("status"), "unknown"),
        message=_str(entry.get("message")), requested=_count(entry.get("scenarios")),
        wall_seconds=_num(entry.get("wall_seconds")),
        failed_scenarios=[FailedScenario(folder=str(k), reason=_str(v, str(v)))
                          for k, v in failed.items()] if isinstance(failed, dict) else [],
        lost=len(failed) if isinstance(failed, dict) else 0,
        fill_of=_str(entry.get("fill_of")) or None, fill_cause=_str(entry.get("fill_cause")) or None,
        fill_classes=[str(c) for c in entry.get("fill_classes") or [] if isinstance(c, str)]
        if isinstance(entry.get("fill_classes"), list) else [])


def _read_manifest(run_dir: Path, b: BehaviorSummary) -> None:
    """Status, stage times and model usage from run.json; the text and domain when batch.json
    lacks them."""
    raw = RunFolder(run_dir).read_manifest_raw()
    if not raw.ok:
        b.missing.append(f"run.json: {raw.problem}")
        return
    run = raw.value
    b.run_status = _str(run.get("status")) or None
    behavior = run.get("behavior") if isinstance(run.get("behavior"), dict) else {}
    b.text = b.text or _str(behavior.get("text"))
    b.domain = b.domain or _str(behavior.get("domain"))
    timings = run.get("timings") if isinstance(run.get("timings"), dict) else {}
    b.timings = {str(k): v for k, v in ((k, _num(v)) for k, v in timings.items()) if v is not None}
    usage = run.get("usage") if isinstance(run.get("usage"), dict) else {}
    total = usage.get("total") if isinstance(usage.get("total"), dict) else {}
    b.usage = {k: total[k] for k in USAGE_KEYS if _num(total.get(k)) is not None}


def _count_scenarios(record: RunRecord, b: BehaviorSummary) -> list[str]:
    """Verdict and causal counts of a run's scenarios; returns the feasible ones' texts."""
    lost = {f.folder for f in b.failed_scenarios}
    statuses: Counter[str] = Counter()
    causal: Counter[str] = Counter()
    texts = []
    b.scenario_folders = len(record.scenarios)
    for s in record.scenarios:
        if s.feasible is None:  # no readable verdict: unfinished, or lost by the batch
            if s.id not in lost:
                b.unfinished.append(s.id)
            continue
        statuses[s.status] += 1
        cause = (s.causal or "").split(":", 1)[0].strip()
        if cause:
            causal[cause] += 1
        if s.feasible:
            b.caused += cause == "caused"
            if s.text:
                texts.append(s.text)
    b.finished, b.statuses, b.causal = sum(statuses.values()), dict(statuses), dict(sorted(causal.items()))
    judged = {s.id for s in record.scenarios if s.feasible is not None}
    b.lost = sum(f.folder not in judged for f in b.failed_scenarios)
    b.verified = statuses.get("verified", 0)
    b.feasible = sum(statuses.get(s, 0) for s in FEASIBLE_STATUSES)
    return texts


def _policy_tests(run_dir: Path, text: str) -> list[PolicyTests]:
    """Each policy's results under RUN/tests/ (what ``regen test`` writes), as counts."""
    found = load_tests(run_dir, [], text)
    if found is None:
        return []
    return [PolicyTests(folder=p.folder, policy=p.policy, tests=len(p.ran), passed=p.count("passed"),
                        failed=p.count("failed"), collisions=p.collisions,
                        collision_rate=p.collision_rate, problem=p.problem) for p in found.policies]


def summarize_behavior(batch_dir: Path, number: int, entry: dict[str, Any]) -> tuple[BehaviorSummary, list[str]]:
    """One behavior's summary from batch.json's ``entry`` and its run folder, and the texts of
    its feasible scenarios (for diversity). Never raises for missing or broken files."""
    b = _from_entry(number, entry)
    run_dir = batch_dir / b.folder
    texts: list[str] = []
    if not (run_dir / RunFolder.MANIFEST).is_file() and not (run_dir / RunFolder.SCENARIOS).is_dir():
        b.missing.append("run folder: not started" if b.status in ("pending", "unknown") else
                         "run folder: nothing written")
    else:
        _read_manifest(run_dir, b)
        try:
            texts = _count_scenarios(load_run(run_dir), b)
        except ConfigError as exc:  # neither run.json nor scenarios/: nothing to count
            b.missing.append(str(exc))
        if not (run_dir / RunFolder.SUMMARY).is_file():
            b.missing.append("summary.json: missing (the run has not finished)")
        if (run_dir / RunFolder.REPORT).is_file():
            b.report = href(b.folder, RunFolder.REPORT)
        else:
            b.missing.append("report.html: missing")
        b.tests = _policy_tests(run_dir, b.text)
    if b.unfinished:
        b.missing.append(f"{len(b.unfinished)} scenario(s) without a verdict yet")
    if b.status not in ("done", "failed") and b.requested is not None:  # a done run may make fewer
        b.not_started = max(b.requested - b.finished - len(b.unfinished) - b.lost, 0)
    return b, texts


def _totals(behaviors: Sequence[BehaviorSummary]) -> Totals:
    t = Totals(behaviors=len(behaviors))
    t.by_status = dict(Counter(b.status for b in behaviors))
    statuses: Counter[str] = Counter()
    causal: Counter[str] = Counter()
    timings: Counter[str] = Counter()
    usage: dict[str, Any] = {}
    for b in behaviors:
        t.requested += b.requested or 0
        t.scenario_folders += b.scenario_folders
        t.finished += b.finished
        t.verified, t.feasible, t.caused = t.verified + b.verified, t.feasible + b.feasible, t.caused + b.caused
        t.failed_scenarios += len(b.failed_scenarios)
        statuses.update(b.statuses)
        causal.update(b.causal)
        timings.update(b.timings)
        usage = merge_usage(usage, b.usage)
        t.tests += sum(p.tests for p in b.tests)
        t.collisions += sum(p.collisions for p in b.tests)
    t.statuses, t.causal, t.usage = dict(statuses), dict(sorted(causal.items())), usage
    t.timings = {k: float(v) for k, v in timings.items()}
    return t


# --- the summary -------------------------------------------------------------------------------


def _batch_folder(batch_dir: Path) -> Path:
    batch_dir = Path(batch_dir)
    if not batch_dir.is_dir():
        raise ConfigError(f"no batch folder at {batch_dir}: pass the --out folder of 'regen batch'")
    return batch_dir


def summarize(batch_dir: Path, *, embeddings: bool = True, encoder: Encoder | None = None) -> BatchSummary:
    """The batch's summary as a model (see :func:`summarize_batch`); writes nothing."""
    batch_dir = _batch_folder(batch_dir)
    out = BatchSummary()
    texts: dict[str, list[str]] = {}
    entries = _read_batch(batch_dir, out)
    for number, entry in enumerate(entries, start=1):
        b, feasible_texts = summarize_behavior(batch_dir, number, entry)
        out.behaviors.append(b)
        if feasible_texts:
            texts.setdefault(b.domain or "unknown", []).extend(feasible_texts)
    out.totals = _totals(out.behaviors)
    out.diversity = batch_diversity(texts, embeddings=embeddings, encoder=encoder)
    if any(b.fill_of for b in out.behaviors):
        out.fill = fill_summary(batch_dir, entries)
    return out


def summarize_batch(batch_dir: Path, *, embeddings: bool = True, encoder: Encoder | None = None
                    ) -> dict[str, Any]:
    """Summarize the batch folder and write ``batch_dir/summary.json``; returns what it wrote.

    Per behavior: the batch's status and message, counts by verdict status, feasible, verified
    and feasible-and-caused counts, causal counts, the scenarios the batch lost with the reason,
    wall seconds per stage, model calls and tokens, policy collision rates (``regen test``);
    then totals, and diversity over every feasible scenario of the batch. ``embeddings=False``
    skips the embedding metric; ``encoder`` replaces the default sentence encoder (tests).
    Works on a batch that is still running or failed; raises only when ``batch_dir`` is not a
    folder (:class:`regen.errors.ConfigError`).
    """
    data = summarize(batch_dir, embeddings=embeddings, encoder=encoder).model_dump(mode="json")
    write_json(Path(batch_dir) / SUMMARY_FILE, data)
    return data


# --- the page ----------------------------------------------------------------------------------


@dataclass
class Segment:
    """One part of a behavior's verdict bar."""

    status: str  # a verdict status, or failed, unfinished, not_started
    count: int
    share: float  # [%] of the bar


def verdict_bar(b: BehaviorSummary) -> list[Segment]:
    """The behavior's scenarios by verdict status, then those lost, unfinished and not started."""
    parts = [(s, b.statuses.get(s, 0)) for s in BAR_ORDER]
    parts += [(s, n) for s, n in sorted(b.statuses.items()) if s not in BAR_ORDER]
    parts += [("failed", b.lost), ("unfinished", len(b.unfinished)), ("not_started", b.not_started)]
    total = sum(n for _, n in parts)
    return [Segment(s, n, round(100 * n / total, 2)) for s, n in parts if n]


def _stages(behaviors: Iterable[BehaviorSummary]) -> list[str]:
    seen = dict.fromkeys(k for b in behaviors for k in b.timings)
    return [s for s in STAGE_ORDER if s in seen] + [s for s in seen if s not in STAGE_ORDER]


def render_batch_report(summary: BatchSummary, files: dict[str, str] | None = None) -> str:
    """The batch page as HTML text; ``files`` are the batch folder's own files to link (name -> href)."""
    env = environment("regen.batch", "templates", html=True, finalize=clean_text)
    env.filters.update(value=fmt_value, seconds=fmt_seconds, percent=fmt_percent, time=fmt_time)
    css = (resources.files("regen.report") / "static" / "report.css").read_text(encoding="utf-8")
    return env.get_template("batch_report.html.j2").render(
        batch=summary, css=css, stages=_stages(summary.behaviors), bar=verdict_bar,
        metrics=METRICS, files=files or {},
        generated=datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S"))


def write_batch_report(batch_dir: Path, summary: dict[str, Any] | None = None) -> Path:
    """Write ``batch_dir/report.html`` and return its path: a table of the behaviors with their
    counts, a bar of verdict statuses each, stage wall times, links to each run's report,
    the scenarios the batch lost with the reason, policy collision rates and diversity.

    ``summary`` is what :func:`summarize_batch` returned; without it the batch is summarized
    now (which writes ``summary.json`` too). Everything model-written is escaped.
    """
    batch_dir = _batch_folder(batch_dir)
    data = summary if summary is not None else summarize_batch(batch_dir)
    view = BatchSummary.model_validate(data)
    files = {name: href(name) for name in (BATCH_FILE, SUMMARY_FILE) if (batch_dir / name).is_file()}
    out = atomic_write_text(batch_dir / REPORT_FILE, render_batch_report(view, files))
    log.info("wrote %s", out)
    return out
