"""Edge-construction accuracy (paper appendix, Table "Accuracy of Edge Creation").

Labeled file (JSON lines, UTF-8, one example per line; blank lines and lines starting with
``#`` are ignored)::

    {"kind": "event->event", "source": "the ego-vehicle stopped abruptly",
     "candidate": "a jaywalker walked in front", "label": true, "domain": "driving"}
    {"kind": "entity->event", "source": "emergency vehicle approaching from behind",
     "candidate": "bicycle", "label": false, "domain": "driving"}
    {"kind": "property->entity", "source": "ambulance", "candidate": "siren: on", "label": true,
     "context": "ego-vehicle stopped abruptly <- emergency vehicle approaching from behind",
     "domain": "driving"}

- ``kind``: ``event->event`` (candidate cause event -> source event), ``entity->event``
  (candidate asset id -> source event), ``property->entity`` (candidate property value ->
  source entity);
- ``split`` (optional): ``tune`` (prompt and threshold work may look at it) or ``test`` (never
  looked at while tuning; the figure to report); rows without one form the group ``all``.
  The bundled sets carry a fixed split, alternating within each (domain, kind, source);
- ``label``: whether the edge is plausible; ``context`` (optional): the chain the source sits
  in, behavior first, joined by ``<-`` (the source may end it); ``domain``: a registered domain
  (``regen.domains.names()``). Each domain ships its own labeled rows (its backend's
  ``edge_examples``); ``regen eval --edges example`` runs the rows of every registered domain.

Rows with the same (domain, kind, source, context) form one edge-construction call: the judge
sees all candidates of a source at once, as the paper's edge construction does. Each trial
runs every call once; accuracy, precision, recall and F1 are computed per (domain, kind) over all
rows of the trial and reported as mean and std over trials. A call that raises a RegenError
counts as accepting nothing and is recorded.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Literal, Protocol

import numpy as np
from pydantic import BaseModel, Field, ValidationError

from regen.core.base import Model
from regen.errors import ConfigError, RegenError
from regen.promises.files import read_text

log = logging.getLogger(__name__)

EdgeKindName = Literal["event->event", "entity->event", "property->entity"]
KINDS: tuple[str, ...] = ("event->event", "entity->event", "property->entity")


class EdgeExample(Model):
    kind: EdgeKindName
    source: str = Field(min_length=1)
    candidate: str = Field(min_length=1)
    label: bool
    context: str | None = None
    domain: str = Field(min_length=1)
    split: Literal["tune", "test"] | None = None


class Judge(Protocol):
    """Edge construction under test: the accepted subset of ``candidates`` for ``source``."""

    def __call__(self, kind: str, source: str, candidates: list[str], *,
                 context: str | None = None, domain: str) -> Iterable[str]: ...


class Metrics(BaseModel):
    accuracy: float
    precision: float
    recall: float
    f1: float


class Stat(BaseModel):
    mean: float
    std: float


class GroupResult(BaseModel):
    domain: str
    kind: str
    split: str = "all"  # 'tune', 'test', or 'all' (rows without a split)
    examples: int  # rows
    calls: int  # edge-construction calls per trial
    accuracy: Stat
    precision: Stat
    recall: Stat
    f1: Stat
    trials: list[Metrics] = Field(default_factory=list)
    failed_calls: int = 0  # over all trials


class EdgeReport(BaseModel):
    trials: int
    groups: list[GroupResult]


def load_edge_examples(path: str | Path | list[Path]) -> list[EdgeExample]:
    """Read a labeled JSON-lines file, or several (format in the module doc); errors name the line."""
    if isinstance(path, list):
        return [row for p in path for row in load_edge_examples(p)]
    path = Path(path)
    lines = read_text(path, what="edge examples", give="give a JSON-lines file of labeled edges").split("\n")
    out = []
    for i, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            out.append(EdgeExample.model_validate_json(line))
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(x) for x in first["loc"]) or "line"
            raise ConfigError(f"{path} line {i}: {where}: {first['msg']}") from exc
    if not out:
        raise ConfigError(f"{path} has no labeled examples")
    return out


def bundled_edge_examples() -> list[Path]:
    """The labeled example files that the registered domains ship (one per domain that has one)."""
    from importlib import resources

    from regen import domains

    out = []
    for name in domains.names():
        shipped = domains.backend_class(name).edge_examples
        if shipped is not None:
            out.append(Path(str(resources.files(shipped[0]).joinpath(shipped[1]))))
    return out


def metrics(labels: list[bool], predicted: list[bool]) -> Metrics:
    """Accuracy, precision, recall, F1 of binary predictions.

    An undefined precision (nothing predicted positive) or recall (nothing labeled positive)
    is 1.0 when the other side makes no mistake of that kind either, else 0.0.
    """
    y = np.asarray(labels, dtype=bool)
    p = np.asarray(predicted, dtype=bool)
    tp = int((y & p).sum())
    fp = int((~y & p).sum())
    fn = int((y & ~p).sum())
    acc = float((y == p).mean()) if len(y) else 0.0
    prec = tp / (tp + fp) if tp + fp else (1.0 if fn == 0 else 0.0)
    rec = tp / (tp + fn) if tp + fn else (1.0 if fp == 0 else 0.0)
    f1 = 2 * prec * rec / (prec + rec) if prec + rec else 0.0
    return Metrics(accuracy=acc, precision=prec, recall=rec, f1=f1)


def _stat(values: list[float]) -> Stat:
    arr = np.asarray(values, dtype=np.float64)
    return Stat(mean=float(arr.mean()), std=float(arr.std()))


Group = tuple[str, str, str]  # (domain, kind, split)


def _group(ex: EdgeExample) -> Group:
    return (ex.domain, ex.kind, ex.split or "all")


def evaluate_edges(examples: list[EdgeExample], judge: Judge | None = None, *, trials: int = 5,
                   judge_for_trial: Callable[[int], Judge] | None = None,
                   progress: Callable[[int], None] | None = None) -> EdgeReport:
    """Run ``judge`` over the labeled examples ``trials`` times; metrics per (domain, kind, split).

    ``judge_for_trial(t)`` instead gives a fresh judge per trial, e.g. a model client without
    the answers of earlier trials in its cache, so that trials are independent samples.
    """
    if judge is None and judge_for_trial is None:
        raise ConfigError("evaluate_edges needs a judge")
    if trials < 1:
        raise ConfigError("trials must be at least 1")
    calls: dict[tuple[str, str, str, str | None], list[EdgeExample]] = {}
    for ex in examples:
        calls.setdefault((ex.domain, ex.kind, ex.source, ex.context), []).append(ex)
    groups = sorted({_group(ex) for ex in examples}, key=lambda g: (g[0], KINDS.index(g[1]), g[2]))
    per_trial: dict[Group, list[Metrics]] = {g: [] for g in groups}
    failed: dict[Group, int] = {g: 0 for g in groups}
    for t in range(trials):
        if progress:
            progress(t)
        trial_judge = judge_for_trial(t) if judge_for_trial is not None else judge
        labels: dict[Group, list[bool]] = {g: [] for g in groups}
        preds: dict[Group, list[bool]] = {g: [] for g in groups}
        for (domain, kind, source, context), rows in calls.items():
            candidates = list(dict.fromkeys(r.candidate for r in rows))
            try:
                accepted = {str(c) for c in trial_judge(kind, source, candidates,
                                                  context=context, domain=domain)}
            except RegenError as exc:
                log.warning("edge construction failed for %s %r: %s", kind, source, exc)
                for g in {_group(r) for r in rows}:
                    failed[g] += 1
                accepted = set()
            for r in rows:
                labels[_group(r)].append(r.label)
                preds[_group(r)].append(r.candidate in accepted)
        for g in groups:
            per_trial[g].append(metrics(labels[g], preds[g]))
    out = []
    for g in groups:
        ms = per_trial[g]
        out.append(GroupResult(
            domain=g[0], kind=g[1], split=g[2], examples=sum(1 for e in examples if _group(e) == g),
            calls=sum(1 for k, rows in calls.items() if any(_group(r) == g for r in rows)),
            accuracy=_stat([m.accuracy for m in ms]), precision=_stat([m.precision for m in ms]),
            recall=_stat([m.recall for m in ms]), f1=_stat([m.f1 for m in ms]),
            trials=ms, failed_calls=failed[g]))
    return EdgeReport(trials=trials, groups=out)


def context_chain(context: str | None, source: str) -> list[str]:
    """The chain beyond ``source`` toward the behavior, from a context string.

    Context strings are written as in the paper's appendix, behavior first:
    ``"behavior <- event <- entity"``; the result runs the other way (nearest first) and
    leaves out the source itself: ``context_chain(that, "entity") == ["event", "behavior"]``.
    """
    if not context:
        return []
    parts = [p.strip() for p in context.split("<-") if p.strip()]
    parts.reverse()
    if parts and parts[0].lower() == source.strip().lower():
        parts = parts[1:]
    return parts


def model_judge(llm) -> Judge:
    """The project's own edge construction (``regen.expand.construct:judge_candidates``) as a Judge:
    the same calls expansion makes (one yes/no question per candidate cause, one entity
    selection per event, one property choice per entity), plus the rules it applies after them.

    Imported here rather than at module import, so the rest of evaluation works without the
    expansion package; a missing one is reported before any trial runs.
    """
    try:
        from regen.expand.construct import judge_candidates
    except ImportError as exc:
        raise ConfigError("edge construction (regen.expand.construct.judge_candidates) is not "
                          "available in this installation") from exc

    def judge(kind: str, source: str, candidates: list[str], *, context: str | None = None,
              domain: str) -> set[str]:
        chain = context_chain(context, source)
        return set(judge_candidates(llm, kind, source, candidates, domain=domain, context=chain or None))

    return judge
