"""Coverage of a domain's scenario typology (the NHTSA pre-crash typology for driving): which of
its classes the verified scenarios of some run folders show, per behavior, how often, and which
they do not (``regen eval --coverage``; docs/coverage.md).

A domain brings its typology through :meth:`regen.contract.DomainBackend.typology` (the classes
and the rules that read them off a trace); this module only reads run folders, counts and draws.
Only verified scenarios count (``verdict.json`` feasible); the others are counted as left out.
"""

from __future__ import annotations

import logging
import textwrap
from collections import Counter
from collections.abc import Callable, Iterable
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError

from regen import domains
from regen.contract import Typology
from regen.core.behavior import Behavior
from regen.core.io import write_json
from regen.core.trace import Trace
from regen.errors import ConfigError
from regen.runfolder import RunFolder, read_json, read_model

log = logging.getLogger(__name__)

COVERAGE_JSON = "coverage.json"
COVERAGE_PNG = "coverage.png"
#: how deep under a given folder run folders are looked for: a batch's runs are its subfolders,
#: ``regen falsify``'s candidates are ``OUT/candidates/<cid>/``
SEARCH_DEPTH = 2


class TypologyClassInfo(BaseModel):
    id: str
    number: int
    name: str
    description: str
    simulable: bool = True
    note: str = ""


class ScenarioCoverage(BaseModel):
    """One verified scenario: the classes it shows and what in its trace shows them."""

    run: str  # the run folder
    scenario: str  # its folder name
    behavior: str
    status: str  # the verdict status
    classes: list[str] = Field(default_factory=list)  # class ids, in the typology's order
    why: dict[str, list[str]] = Field(default_factory=dict)  # class id -> what shows it


class LeftOut(BaseModel):
    run: str
    scenario: str
    behavior: str
    reason: str  # 'fsm_incomplete', 'no verdict', 'trace unreadable: ...'


class BehaviorCoverage(BaseModel):
    """One behavior over every run folder that explains it."""

    behavior: str
    domain: str
    runs: list[str] = Field(default_factory=list)
    verified: int = 0  # verified scenarios classified
    left_out: int = 0  # scenarios that did not count (not verified, unfinished, unreadable)
    unclassified: int = 0  # verified scenarios that show no class
    counts: dict[str, int] = Field(default_factory=dict)  # class id -> verified scenarios showing it
    covered: list[str] = Field(default_factory=list)  # class ids shown at least once
    uncovered: list[str] = Field(default_factory=list)  # simulable class ids never shown
    not_simulable: list[str] = Field(default_factory=list)  # class ids the domain cannot show, not shown
    #: uncovered class id -> cause texts that present it and fit this behavior (what
    #: ``regen batch --fill-coverage`` runs); classes no cause of the domain fits are left out
    fill: dict[str, list[str]] = Field(default_factory=dict)


class TypologyCoverage(BaseModel):
    """The coverage of one domain's typology."""

    domain: str
    typology: str
    source: str = ""
    classes: list[TypologyClassInfo] = Field(default_factory=list)
    behaviors: list[BehaviorCoverage] = Field(default_factory=list)
    covered: list[str] = Field(default_factory=list)  # class ids some behavior covers
    scenarios: list[ScenarioCoverage] = Field(default_factory=list)
    left_out: list[LeftOut] = Field(default_factory=list)


class CoverageReport(BaseModel):
    """``coverage.json``."""

    sources: list[str] = Field(default_factory=list)  # the folders given
    runs: list[str] = Field(default_factory=list)  # the run folders found in them
    typologies: list[TypologyCoverage] = Field(default_factory=list)
    #: behaviors whose domain has no typology, as behavior -> why they were not counted
    skipped: dict[str, str] = Field(default_factory=dict)
    files: list[str] = Field(default_factory=list)


# -- finding run folders --------------------------------------------------------------------------


def _is_run(path: Path) -> bool:
    run = RunFolder(path)
    return path.is_dir() and (run.is_run() or (run / run.SCENARIOS).is_dir())


def _runs_under(path: Path, depth: int) -> list[Path]:
    if depth <= 0:
        return []
    try:
        subs = sorted(p for p in path.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return []
    found: list[Path] = []
    for p in subs:
        found += [p] if _is_run(p) else _runs_under(p, depth - 1)
    return found


def find_runs(sources: Iterable[str | Path]) -> list[Path]:
    """The run folders of ``sources``: each a run folder (``run.json`` or ``scenarios/``), or a
    folder holding run folders up to :data:`SEARCH_DEPTH` levels down (a ``regen batch`` folder,
    a ``regen falsify`` folder with ``candidates/``). ConfigError naming a source that is none."""
    runs: list[Path] = []
    for src in sources:
        p = Path(src)
        if not p.exists():
            raise ConfigError(f"{p} does not exist: give a run folder (the --out of regen generate) or a "
                              "folder of run folders (the --out of regen batch or regen falsify)")
        if not p.is_dir():
            raise ConfigError(f"{p} is a file, not a run folder: give the --out folder of regen generate, "
                              "regen batch or regen falsify")
        found = [p] if _is_run(p) else _runs_under(p, SEARCH_DEPTH)
        if not found:
            raise ConfigError(f"{p} is not a run folder (no run.json and no scenarios/ folder) and holds "
                              "none: give the --out folder of regen generate, regen batch or regen falsify")
        runs += [r for r in found if r not in runs]
    if not runs:
        raise ConfigError("no run folders given: regen eval --coverage RUN [RUN...]")
    return runs


# -- classifying ----------------------------------------------------------------------------------


def _run_behavior(run: RunFolder) -> Behavior | None:
    """The behavior run.json names, or None (no run.json, or one that cannot be read)."""
    raw = read_json(run / run.MANIFEST).value
    try:
        return Behavior.model_validate(raw.get("behavior")) if isinstance(raw, dict) else None
    except ValidationError:
        return None


class _Collector:
    """Classifies the scenarios of run folders into the typology of each domain."""

    def __init__(self, typology_of: Callable[[str], Typology | None]):
        self.typology_of = typology_of
        self.typologies: dict[str, Typology | None] = {}
        self.why_none: dict[str, str] = {}  # domain -> why it has no typology here
        self.by_domain: dict[str, TypologyCoverage] = {}
        self.behaviors: dict[tuple[str, str], BehaviorCoverage] = {}
        self.behavior_of: dict[tuple[str, str], Behavior] = {}  # the first one read, with its parameters
        self.skipped: dict[str, str] = {}

    def typology(self, domain: str) -> Typology | None:
        if domain not in self.typologies:
            try:
                self.typologies[domain] = self.typology_of(domain)
                self.why_none[domain] = f"the {domain} domain has no scenario typology"
            except ConfigError as exc:  # a domain this installation does not know
                self.typologies[domain], self.why_none[domain] = None, str(exc)
        return self.typologies[domain]

    def coverage(self, domain: str, typ: Typology) -> TypologyCoverage:
        if domain not in self.by_domain:
            self.by_domain[domain] = TypologyCoverage(
                domain=domain, typology=typ.name, source=typ.source,
                classes=[TypologyClassInfo(id=c.id, number=c.number, name=c.name, description=c.description,
                                           simulable=c.simulable, note=c.note) for c in typ.classes])
        return self.by_domain[domain]

    def behavior(self, domain: str, text: str, run: str, behavior: Behavior | None) -> BehaviorCoverage:
        if behavior is not None and behavior.text == text:
            self.behavior_of.setdefault((domain, text), behavior)
        b = self.behaviors.setdefault((domain, text), BehaviorCoverage(behavior=text, domain=domain))
        if run not in b.runs:
            b.runs.append(run)
        return b

    def add_run(self, path: Path) -> None:
        run = RunFolder(path)
        run_behavior = _run_behavior(run)
        for name in run.scenario_names():
            self.add_scenario(run, name, run_behavior)

    def add_scenario(self, run: RunFolder, name: str, run_behavior: Behavior | None) -> None:
        sf = run.scenario(name)
        scenario = sf.scenario()
        behavior = run_behavior or (scenario.behavior if scenario is not None else None)
        text = behavior.text if behavior is not None else "(unknown behavior)"
        domain = (scenario.domain if scenario is not None else None) or (behavior.domain if behavior else None)
        if domain is None:
            self.skipped.setdefault(text, "no readable scenario.json or run.json says its domain")
            return
        typ = self.typology(domain)
        if typ is None:
            self.skipped.setdefault(text, self.why_none[domain])
            return
        cov = self.coverage(domain, typ)
        b = self.behavior(domain, text, str(run.path), behavior)
        verdict = sf.verdict()
        reason = ("no verdict (unfinished)" if verdict is None else "" if verdict.feasible else verdict.status)
        trace = None
        if not reason:
            got = read_model(sf / sf.TRACE, Trace)
            trace = got.value
            reason = "" if scenario is not None and trace is not None else (
                "scenario.json unreadable" if scenario is None else f"trace.json {got.problem}")
        if reason:
            b.left_out += 1
            cov.left_out.append(LeftOut(run=str(run.path), scenario=name, behavior=text, reason=reason))
            return
        why = typ.explain(scenario, trace)
        classes = [c.id for c in typ.classes if c.id in why]
        b.verified += 1
        b.unclassified += not classes
        for c in classes:
            b.counts[c] = b.counts.get(c, 0) + 1
        cov.scenarios.append(ScenarioCoverage(run=str(run.path), scenario=name, behavior=text,
                                              status=verdict.status, classes=classes,
                                              why={c: why[c] for c in classes}))

    def report(self, sources: list[str], runs: list[Path]) -> CoverageReport:
        for (domain, _), b in self.behaviors.items():
            cov = self.by_domain[domain]
            order = [c.id for c in cov.classes]
            b.counts = {c: b.counts[c] for c in order if c in b.counts}
            b.covered = list(b.counts)
            b.uncovered = [c.id for c in cov.classes if c.simulable and c.id not in b.counts]
            b.not_simulable = [c.id for c in cov.classes if not c.simulable and c.id not in b.counts]
            behavior, typ = self.behavior_of.get((domain, b.behavior)), self.typologies[domain]
            if behavior is not None and typ is not None:
                fill = {c: typ.fill_causes(behavior, c) for c in b.uncovered}
                b.fill = {c: causes for c, causes in fill.items() if causes}
            cov.behaviors.append(b)
        for cov in self.by_domain.values():
            seen = {c for b in cov.behaviors for c in b.counts}
            cov.covered = [c.id for c in cov.classes if c.id in seen]
        return CoverageReport(sources=sources, runs=[str(r) for r in runs],
                              typologies=list(self.by_domain.values()), skipped=self.skipped)


def _domain_typology(domain: str) -> Typology | None:
    return domains.make(domain).typology()


def coverage(sources: Iterable[str | Path], *, out_dir: str | Path | None = None,
             typology_of: Callable[[str], Typology | None] | None = None,
             progress: Callable[[str], None] | None = None) -> CoverageReport:
    """The typology coverage of the verified scenarios under ``sources`` (:func:`find_runs`), per
    behavior; with ``out_dir``, also ``coverage.json`` and ``coverage.png`` there.

    ``typology_of``: the typology of a domain name (default: the registered domain's
    :meth:`~regen.contract.DomainBackend.typology`). ConfigError for a source that holds no run
    folder."""
    sources = [str(s) for s in sources]
    runs = find_runs(sources)
    collector = _Collector(typology_of or _domain_typology)
    for run in runs:
        if progress is not None:
            progress(f"classifying {run}")
        collector.add_run(run)
    report = collector.report(sources, runs)
    if out_dir is not None:
        write_coverage(report, Path(out_dir))
    return report


def write_coverage(report: CoverageReport, out_dir: Path) -> list[Path]:
    """``coverage.png`` (when a typology was counted) and ``coverage.json`` listing it, in ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    if any(t.behaviors for t in report.typologies):
        written.append(coverage_plot(report, out_dir / COVERAGE_PNG))
    json_path = out_dir / COVERAGE_JSON
    report.files = [str(p) for p in written] + [str(json_path)]
    write_json(json_path, report)
    return written + [json_path]


# -- the picture ----------------------------------------------------------------------------------

COVERED = "#2b6cb0"  # covered cells (shade by count)
UNCOVERED = "#e2e2e2"  # simulable, never shown
NOT_SIMULABLE = "#b5b5b5"  # the domain cannot show it
LABEL_CHARS = 80  # class labels longer than this are cut
CHAR_INCH = 0.052  # [in] width of a label character at 7.5 pt
LINE_INCH = 0.15  # [in] height of a label line at 7.5 pt
ROW_INCH = 0.27  # [in] height of a class row
CELL_INCH = 1.25  # [in] width of a behavior column


def coverage_plot(report: CoverageReport, path: str | Path) -> Path:
    """Per typology, a grid of its classes (rows) by behaviors (columns): covered cells blue with
    the number of verified scenarios, uncovered grey, classes the domain cannot simulate darker
    grey marked n/a."""
    import matplotlib

    matplotlib.use("Agg")  # no display; must precede the pyplot import
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgb
    from matplotlib.patches import Patch

    panels = [t for t in report.typologies if t.behaviors]
    cols = max(len(t.behaviors) for t in panels)
    labels_of = {t.domain: [_short(f"{c.number} {c.name}", LABEL_CHARS) for c in t.classes] for t in panels}
    heads_of = {t.domain: [textwrap.fill(b.behavior, 22) + f"\n({b.verified} verified)" for b in t.behaviors]
                for t in panels}
    # margins [in]: the class labels on the left, the behaviors (wrapped) above each panel
    left = 0.3 + CHAR_INCH * max(len(x) for labels in labels_of.values() for x in labels)
    head = 0.7 + LINE_INCH * max(h.count("\n") + 1 for heads in heads_of.values() for h in heads)
    heights = [ROW_INCH * len(t.classes) for t in panels]
    width, height = left + CELL_INCH * cols + 0.3, sum(heights) + len(panels) * head + 0.5
    fig = plt.figure(figsize=(width, height))
    base = to_rgb(COVERED)
    y = height  # [in] the top of the next panel's heading
    for t in panels:
        h = ROW_INCH * len(t.classes)
        simulable = sum(c.simulable for c in t.classes)
        fig.text(0.5, (y - 0.1) / height, f"{t.typology} ({t.domain}): {len(t.covered)} of {len(t.classes)} "
                 f"classes covered ({simulable} simulable)", ha="center", va="top", fontsize=10)
        y -= head + h
        ax = fig.add_axes((left / width, y / height, CELL_INCH * len(t.behaviors) / width, h / height))
        top = max([n for b in t.behaviors for n in b.counts.values()] or [1])
        for j, b in enumerate(t.behaviors):
            for i, c in enumerate(t.classes):
                n = b.counts.get(c.id, 0)
                if n:
                    share = 0.35 + 0.65 * n / top
                    color = tuple(1 - share * (1 - v) for v in base)
                    text, ink = str(n), ("white" if share > 0.6 else "black")
                else:
                    color, text, ink = (UNCOVERED, "", "black") if c.simulable else (NOT_SIMULABLE, "n/a", "#555555")
                ax.add_patch(plt.Rectangle((j, i), 1, 1, facecolor=color, edgecolor="white", linewidth=1.5))
                if text:
                    ax.text(j + 0.5, i + 0.5, text, ha="center", va="center", fontsize=8, color=ink)
        ax.set_xlim(0, len(t.behaviors))
        ax.set_ylim(len(t.classes), 0)
        ax.set_yticks([i + 0.5 for i in range(len(t.classes))], labels_of[t.domain], fontsize=7.5)
        ax.set_xticks([j + 0.5 for j in range(len(t.behaviors))], heads_of[t.domain], fontsize=7.5)
        ax.xaxis.tick_top()
        ax.tick_params(length=0)
        for side in ax.spines.values():
            side.set_visible(False)
    fig.legend(handles=[Patch(color=COVERED, label="covered (verified scenarios)"),
                        Patch(color=UNCOVERED, label="not covered"),
                        Patch(color=NOT_SIMULABLE, label="n/a: cannot occur in this simulator")],
               loc="lower center", ncol=3, fontsize=8, frameon=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _short(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


# -- the terminal ---------------------------------------------------------------------------------


def print_coverage(report: CoverageReport, console) -> None:
    """The coverage as rich tables: per typology, its classes by behavior (B1, B2, ... with the
    behaviors listed below), then what each behavior leaves uncovered and what was left out."""
    from rich.markup import escape
    from rich.table import Table

    for t in report.typologies:
        table = Table(title=f"{escape(t.typology)} coverage ({escape(t.domain)}): {len(t.covered)} of "
                            f"{len(t.classes)} classes covered by verified scenarios")
        table.add_column("#", justify="right")
        table.add_column("class")
        for j in range(len(t.behaviors)):
            table.add_column(f"B{j + 1}", justify="right")
        table.add_column("total", justify="right")
        for c in t.classes:
            counts = [b.counts.get(c.id, 0) for b in t.behaviors]
            cells = [str(n) if n else ("·" if c.simulable else "[dim]n/a[/]") for n in counts]
            total = sum(counts)
            name = escape(c.name) if c.simulable or total else f"[dim]{escape(c.name)}[/]"
            table.add_row(str(c.number), name, *cells, f"[bold]{total}[/]" if total else "·")
        table.add_section()
        table.add_row("", "unclassified", *(str(b.unclassified) for b in t.behaviors),
                      str(sum(b.unclassified for b in t.behaviors)))
        table.add_row("", "verified scenarios", *(str(b.verified) for b in t.behaviors),
                      str(sum(b.verified for b in t.behaviors)))
        table.add_row("", "left out (not verified)", *(str(b.left_out) for b in t.behaviors),
                      str(sum(b.left_out for b in t.behaviors)))
        console.print(table)
        numbers = {c.id: c.number for c in t.classes}
        for j, b in enumerate(t.behaviors):
            covered = ", ".join(str(numbers[c]) for c in b.covered) or "none"
            fill = ", ".join(str(numbers[c]) for c in b.fill) or "none"
            console.print(f"B{j + 1} {escape(b.behavior)} ({b.verified} verified, {b.left_out} left out): "
                          f"covers {covered}; not covered but fitting it (--fill-coverage): {fill}")
        n_a = [str(c.number) for c in t.classes if not c.simulable]
        console.print(f"[dim]n/a: classes {', '.join(n_a)} cannot occur in this simulator (docs/coverage.md)[/]")
        reasons = Counter(x.reason for x in t.left_out)
        if reasons:
            console.print(f"left out: {len(t.left_out)} scenario(s) not verified ("
                          + ", ".join(f"{escape(r)}: {n}" for r, n in reasons.most_common()) + ")")
    for behavior, why in report.skipped.items():
        console.print(f"[yellow]not counted: {escape(behavior)}: {escape(why)}[/yellow]")


__all__ = ["COVERAGE_JSON", "COVERAGE_PNG", "BehaviorCoverage", "CoverageReport", "LeftOut", "ScenarioCoverage",
           "TypologyCoverage", "coverage", "coverage_plot", "find_runs", "print_coverage", "write_coverage"]
