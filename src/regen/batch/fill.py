"""``regen batch --fill-coverage``: after the spec's behaviors ran, runs that aim at the classes
of the domain's scenario typology (the NHTSA pre-crash typology for driving) that a behavior's
verified scenarios do not show yet.

For each behavior of a domain with a typology (:meth:`regen.contract.DomainBackend.typology`),
the coverage of its own run folder (:mod:`regen.evaluation.coverage`) gives the uncovered
classes; each class's data names cause texts that present it and the behaviors they fit
(:meth:`~regen.contract.Typology.fill_causes`). Every distinct cause becomes one extra run of that
behavior, ``regen generate BEHAVIOR --cause CAUSE -n 1`` in effect (the insisted cause is
grounded first, and only it: one cause, one node, depth 1), into ``DIR/NN-fill-<class>-<cause>/``
(NN: the behavior's place in the spec; class: the number of the first class the cause aims at). The
plan depends only on the spec's own runs, so a rerun plans the same runs and resumes them.
What the fill added, per behavior, is :func:`fill_summary` (in ``summary.json``).
"""

from __future__ import annotations

import logging
from pathlib import Path

from pydantic import Field

from regen import domains
from regen.batch.spec import PlannedBehavior
from regen.core.base import Model
from regen.errors import ConfigError
from regen.evaluation.coverage import CoverageReport, coverage
from regen.promises.names import slug

log = logging.getLogger(__name__)

FILL = "fill"  # the word in a fill run's folder name: NN-fill-<class>-<cause>


class FillPlan(Model):
    """One extra run: the behavior of the spec's ``fill_of`` folder with ``cause`` insisted on,
    aimed at the typology classes ``classes``."""

    folder: str
    fill_of: str
    cause: str
    classes: list[str] = Field(default_factory=list)


def _covered(report: CoverageReport) -> set[str]:
    return {c for t in report.typologies for b in t.behaviors for c in b.counts}


def plan_fill(out: Path, planned: list[PlannedBehavior], names: list[str],
              done: set[str] | None = None) -> list[tuple[FillPlan, PlannedBehavior]]:
    """The fill runs of a batch: for each spec behavior (folder ``names[i]`` in ``out``; only
    those in ``done`` when given) whose domain has a typology, one run per distinct cause text
    that presents an uncovered class and fits the behavior, with the entry's settings but that
    cause insisted on and one scenario."""
    out_plan: list[tuple[FillPlan, PlannedBehavior]] = []
    taken = set(names)
    for i, (p, name) in enumerate(zip(planned, names, strict=True), start=1):
        if done is not None and name not in done:
            continue
        typology = domains.make(p.behavior.domain).typology()
        if typology is None:
            continue
        try:
            covered = _covered(coverage([out / name]))
        except ConfigError as exc:  # the behavior wrote no run folder
            log.info("no coverage fill for %s: %s", name, exc)
            continue
        causes: dict[str, list[str]] = {}  # cause text -> the classes it aims at
        for c in typology.classes:
            if c.id in covered:
                continue
            for text in typology.fill_causes(p.behavior, c.id)[:1]:
                causes.setdefault(text, []).append(c.id)
        width = max(2, len(str(len(planned))))
        for text, classes in causes.items():
            number = typology.get(classes[0]).number  # one cause per class: unique in the behavior
            folder = f"{i:0{width}d}-{FILL}-{number}-{slug(text, fallback='cause')}"
            while folder in taken:
                folder += "-x"
            taken.add(folder)
            settings = p.settings.model_copy(update={"forced_causes": [text], "candidates": [], "max_scenarios": 1,
                                                     "depth": 1, "max_nodes": 1, "causes": 1})
            entry = p.entry.model_copy(update={"cause": [text], "candidate": [], "scenarios": 1,
                                               "depth": 1, "max_nodes": 1, "causes": 1})
            out_plan.append((FillPlan(folder=folder, fill_of=name, cause=text, classes=classes),
                             p.model_copy(update={"entry": entry, "settings": settings, "lines": []})))
    return out_plan


class FillRun(Model):
    """One fill run in the summary: its cause, what it aimed at and what it showed."""

    folder: str
    cause: str
    aimed: list[str] = Field(default_factory=list)  # class labels ('27 Lead vehicle stopped')
    covered: list[str] = Field(default_factory=list)  # class labels its verified scenario shows
    verified: int = 0


class FillSummary(Model):
    """What the fill added to one behavior's coverage."""

    folder: str  # the spec behavior's run folder
    text: str
    typology: str = ""
    before: list[str] = Field(default_factory=list)  # class labels covered by the behavior's own run
    after: list[str] = Field(default_factory=list)  # with the fill runs
    added: list[str] = Field(default_factory=list)  # after, not before
    runs: list[FillRun] = Field(default_factory=list)
    problem: str | None = None  # why it could not be counted


def fill_summary(batch_dir: Path, entries: list[dict]) -> list[FillSummary]:
    """Per spec behavior that has fill runs (``entries`` of batch.json with ``fill_of``): the
    typology classes covered before and after the fill, what it added and what each run showed.
    Never raises: a run that cannot be read is a ``problem``."""
    fills: dict[str, list[dict]] = {}
    for e in entries:
        of = e.get("fill_of")
        if isinstance(of, str) and of:
            fills.setdefault(of, []).append(e)
    texts = {e.get("folder"): e.get("text", "") for e in entries}
    out = []
    for of, runs in fills.items():
        s = FillSummary(folder=of, text=str(texts.get(of) or ""))
        try:
            own = coverage([batch_dir / of])
            label = {c.id: f"{c.number} {c.name}" for t in own.typologies for c in t.classes}
            s.typology = own.typologies[0].typology if own.typologies else ""
            before = _covered(own)
            after = set(before)
            for e in runs:
                run = FillRun(folder=str(e.get("folder")), cause=str(e.get("fill_cause") or ""),
                              aimed=[label.get(c, c) for c in e.get("fill_classes") or []])
                if (batch_dir / run.folder).is_dir():
                    got = coverage([batch_dir / run.folder])
                    mine = _covered(got)
                    label.update({c.id: f"{c.number} {c.name}" for t in got.typologies for c in t.classes})
                    run.covered = [label.get(c, c) for c in sorted(mine, key=_number(label))]
                    run.verified = sum(b.verified for t in got.typologies for b in t.behaviors)
                    after |= mine
                s.runs.append(run)
            s.before = [label.get(c, c) for c in sorted(before, key=_number(label))]
            s.after = [label.get(c, c) for c in sorted(after, key=_number(label))]
            s.added = [label.get(c, c) for c in sorted(after - before, key=_number(label))]
        except ConfigError as exc:
            s.problem = str(exc)
        out.append(s)
    return out


def _number(label: dict[str, str]):
    def key(class_id: str) -> tuple[int, str]:
        head = label.get(class_id, "").split(" ", 1)[0]
        return (int(head) if head.isdigit() else 10**6, class_id)

    return key


__all__ = ["FILL", "FillPlan", "FillRun", "FillSummary", "fill_summary", "plan_fill"]
