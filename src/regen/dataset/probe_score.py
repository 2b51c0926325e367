"""The scores of a probe (:mod:`regen.dataset.probe`) and its files.

- accuracy (exact match with the key) overall, per layer, per behavior and per cause category
  (the asset categories of the sample's cause entities), with the unscored questions counted;
- the planning layer's confusion matrix (rows: the simulation's action, columns: the model's),
  drawn as ``confusion_planning.png``;
- the counterfactual flips: for each two samples sharing a ``pair_id`` (a scenario and its
  what-if or test variant), whether the model's planning answer changed between them and
  whether it should have (their keys differ).

``probe.json`` holds every question (qa_id, how it was asked, the answer, the key, whether it
is correct) and the scores; ``report.md`` says the same in a few lines. Both are deterministic:
sorted keys, no time stamp, no absolute path.
"""

from __future__ import annotations

import io
import json
from collections import defaultdict
from dataclasses import asdict, dataclass
from itertools import combinations
from pathlib import Path
from typing import TYPE_CHECKING, Any

from regen.core.io import atomic_write_bytes
from regen.dataset.labels import LABELS

if TYPE_CHECKING:
    from regen.dataset.probe import Asked, ProbeResult

PROBE_JSON, REPORT, CONFUSION = "probe.json", "report.md", "confusion_planning.png"
NO_ANSWER = "(no answer)"  # the confusion matrix's column of questions without a valid option


@dataclass
class Tally:
    asked: int = 0
    correct: int = 0

    @property
    def accuracy(self) -> float | None:
        return self.correct / self.asked if self.asked else None

    def add(self, correct: bool) -> None:
        self.asked += 1
        self.correct += int(correct)

    def as_dict(self) -> dict[str, Any]:
        return {"asked": self.asked, "correct": self.correct, "accuracy": self.accuracy}


@dataclass
class Flips:
    """Pairs of samples (sharing a pair_id) whose planning questions were both answered."""

    pairs: int = 0
    correct: int = 0  # the model's action changed, and the keys differ
    wrong: int = 0  # the model's action changed, the keys are the same
    missed: int = 0  # the keys differ, the model's action did not change
    kept: int = 0  # neither changed

    @property
    def rate(self) -> float | None:
        """The share of pairs in which the model's action changed."""
        return (self.correct + self.wrong) / self.pairs if self.pairs else None


@dataclass
class Confusion:
    truth: list[str]  # row labels
    answers: list[str]  # column labels (NO_ANSWER last where a question got none)
    counts: list[list[int]]  # [truth][answer]


@dataclass
class Score:
    overall: Tally
    by_layer: dict[str, Tally]
    by_behavior: dict[str, Tally]
    by_cause: dict[str, Tally]
    unscored: int  # questions with no single option (key None)
    not_asked: int  # scored questions past --limit
    no_answer: int  # asked, but no valid option after the re-asks (counted wrong)
    flips: Flips
    confusion: Confusion


def score(result: ProbeResult) -> Score:
    """The scores of ``result``'s answered questions."""
    samples = result.dataset.samples
    overall = Tally()
    by: dict[str, dict[str, Tally]] = {k: defaultdict(Tally) for k in ("layer", "behavior", "cause")}
    for layer in result.layers:
        by["layer"][layer] = Tally()
    for r in result.rows:
        if r.correct is None:
            continue
        s = samples[r.sample_id]
        for tally in (overall, by["layer"][r.layer], by["behavior"][s.behavior], by["cause"][s.cause]):
            tally.add(r.correct)
    return Score(overall=overall, by_layer=dict(by["layer"]), by_behavior=dict(sorted(by["behavior"].items())),
                 by_cause=dict(sorted(by["cause"].items())),
                 unscored=sum(r.key is None for r in result.rows),
                 not_asked=sum(r.key is not None and r.asked is None for r in result.rows),
                 no_answer=sum(r.asked is not None and r.answer is None for r in result.rows),
                 flips=flips(result), confusion=confusion(result.rows))


def _planning(rows: list[Asked]) -> list[Asked]:
    return [r for r in rows if r.layer == "planning" and r.correct is not None]


def confusion(rows: list[Asked]) -> Confusion:
    """The planning layer's confusion matrix over the labels that occur, in label order."""
    planning = _planning(rows)
    order = list(LABELS)
    truth = [k for k in order if any(r.key == k for r in planning)]
    answers = [k for k in order if k in truth or any(r.answer == k for r in planning)]
    if any(r.answer is None for r in planning):
        answers.append(NO_ANSWER)
    counts = [[sum(r.key == t and (r.answer or NO_ANSWER) == a for r in planning) for a in answers] for t in truth]
    return Confusion(truth=truth, answers=answers, counts=counts)


def flips(result: ProbeResult) -> Flips:
    """Each two samples of a pair_id whose planning questions got an answer: did the model's
    action change between them, and should it have (their keys differ)."""
    first: dict[str, Asked] = {}
    for r in _planning(result.rows):  # one planning question a sample (the first, in qa_id order)
        if r.answer is not None:
            first.setdefault(r.sample_id, r)
    groups: dict[str, list[Asked]] = defaultdict(list)
    for sid, r in sorted(first.items()):
        groups[result.dataset.samples[sid].pair_id].append(r)
    out = Flips()
    for members in groups.values():
        for a, b in combinations(members, 2):
            out.pairs += 1
            should, did = a.key != b.key, a.answer != b.answer
            if did and should:
                out.correct += 1
            elif did:
                out.wrong += 1
            elif should:
                out.missed += 1
            else:
                out.kept += 1
    return out


def draw_confusion(conf: Confusion, path: Path, title: str) -> None:
    """The confusion matrix as a PNG: rows the truth, columns the answer, counts in the cells."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows, cols = max(1, len(conf.truth)), max(1, len(conf.answers))
    # [in]: room for the tick labels and the axis titles beside the cells, at least a square's worth
    fig = Figure(figsize=(max(4.0, 2.2 + 1.1 * cols), max(3.2, 1.8 + 0.55 * rows)), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    data = conf.counts if conf.counts else [[0]]
    top = max(max(r) for r in data) or 1
    ax.imshow(data, cmap="Blues", vmin=0, vmax=top, aspect="auto")
    for i, row in enumerate(conf.counts):
        for j, n in enumerate(row):
            ax.text(j, i, str(n), ha="center", va="center", fontsize=11,
                    color="white" if n > top / 2 else "black")
    ax.set_xticks(range(len(conf.answers)), list(conf.answers), rotation=30, ha="right")
    ax.set_yticks(range(len(conf.truth)), list(conf.truth))
    ax.set_xlabel("the model's answer")
    ax.set_ylabel("truth (the simulation)")
    ax.set_title(title, fontsize=10)
    if not conf.truth:
        ax.text(0, 0, "no planning question answered", ha="center", va="center")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})  # no version stamp: same scores, same bytes
    atomic_write_bytes(path, buf.getvalue())


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


def summary(result: ProbeResult, sc: Score) -> dict[str, Any]:
    """The scores as probe.json holds them."""
    return {
        "overall": sc.overall.as_dict(),
        "by_layer": {k: v.as_dict() for k, v in sc.by_layer.items()},
        "by_behavior": {k: v.as_dict() for k, v in sc.by_behavior.items()},
        "by_cause_category": {k: v.as_dict() for k, v in sc.by_cause.items()},
        "unscored": sc.unscored, "not_asked": sc.not_asked, "no_answer": sc.no_answer,
        "flips": {**asdict(sc.flips), "rate": sc.flips.rate},
        "confusion_planning": asdict(sc.confusion),
    }


def report(result: ProbeResult, sc: Score) -> str:
    """report.md: the mode, the accuracy table, the unscored count, the flips and the files."""
    f = sc.flips
    lines = [f"# Probe of {result.dataset.path.name} with {result.provider}", ""]
    lines.append(result.mode.note or ("Asked with the key frames as pictures"
                                      + (" and the privileged information as text." if result.mode.privileged
                                         else ".")))
    lines += ["", "| group | asked | correct | accuracy |", "|---|---|---|---|",
              f"| overall | {sc.overall.asked} | {sc.overall.correct} | {_pct(sc.overall.accuracy)} |"]
    for kind, groups in (("layer", sc.by_layer), ("behavior", sc.by_behavior), ("cause", sc.by_cause)):
        lines += [f"| {kind}: {k} | {v.asked} | {v.correct} | {_pct(v.accuracy)} |" for k, v in groups.items()]
    lines += ["", f"Unscored (no single option): {sc.unscored}. Not asked (--limit): {sc.not_asked}. "
              f"No valid answer (counted wrong): {sc.no_answer}.", "",
              f"Counterfactual pairs: {f.pairs}; flips correct {f.correct}, flips wrong {f.wrong}, "
              f"missed flips {f.missed}, kept {f.kept} (flip rate {_pct(f.rate)}).", "",
              (f"Planning confusion matrix: [{CONFUSION}]({CONFUSION}); " if "planning" in result.layers else "")
              + f"every question: [{PROBE_JSON}]({PROBE_JSON})."]
    return "\n".join(lines) + "\n"


def write_results(result: ProbeResult) -> Score:
    """probe.json, report.md and confusion_planning.png into ``result.out``."""
    assert result.out is not None
    sc = score(result)
    out = result.out
    out.mkdir(parents=True, exist_ok=True)
    doc = {"dataset": result.dataset.path.name, "provider": result.provider, "layers": list(result.layers),
           "asked_with": result.mode.asked, "privileged": result.mode.privileged, "note": result.mode.note,
           "summary": summary(result, sc), "questions": [r.as_dict() for r in result.rows]}
    atomic_write_bytes(out / PROBE_JSON, (json.dumps(doc, indent=1, sort_keys=True, ensure_ascii=False) + "\n").encode())
    atomic_write_bytes(out / REPORT, report(result, sc).encode())
    result.files = [PROBE_JSON, REPORT]
    if "planning" in result.layers:
        title = (f"planning: the ego's action ({sum(map(sum, sc.confusion.counts))} questions, "
                 f"accuracy {_pct(sc.by_layer['planning'].accuracy)})")
        draw_confusion(sc.confusion, out / CONFUSION, title)
        result.files.insert(0, CONFUSION)
    result.score = sc
    return sc


__all__ = ["CONFUSION", "Confusion", "Flips", "NO_ANSWER", "PROBE_JSON", "REPORT", "Score", "Tally", "confusion",
           "draw_confusion", "flips", "report", "score", "summary", "write_results"]
