"""One call for the whole evaluation: what ``regen eval`` runs.

Given text sets and run folders, it measures diversity under the paper's protocol, and for run
folders also the feasibility breakdown and controllability; given a labeled edge file and a
judge, edge-construction accuracy. Results come back as one pydantic model and, with an output
folder, as ``eval.json`` plus PNG plots.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, Field

from regen.core.io import write_json
from regen.errors import ConfigError
from regen.evaluation import plots
from regen.evaluation.controllability import ControllabilityReport, controllability
from regen.evaluation.diversity import SetDiversity, compare_sets
from regen.evaluation.edges import EdgeReport, Judge, evaluate_edges, load_edge_examples
from regen.evaluation.feasibility import FeasibilityReport, feasibility_breakdown
from regen.evaluation.textsets import TextSet, load_text_sets

log = logging.getLogger(__name__)


class EvalSettings(BaseModel):
    sample_size: int | None = None  # n; None = smallest set size
    repeats: int = 10
    seed: int = 0
    embeddings: bool = True
    self_bleu: bool = True
    edge_trials: int = 5


class EvalReport(BaseModel):
    settings: EvalSettings
    sources: dict[str, str] = Field(default_factory=dict)  # set name -> where it came from
    diversity: list[SetDiversity] = Field(default_factory=list)
    feasibility: FeasibilityReport | None = None
    controllability: ControllabilityReport | None = None
    edges: EdgeReport | None = None
    skipped: dict[str, str] = Field(default_factory=dict)  # set name -> why it was left out
    files: list[str] = Field(default_factory=list)  # written JSON/PNG paths


def evaluate(
    sources: list[str | Path] | None = None,
    *,
    settings: EvalSettings | None = None,
    edges_file: str | Path | list[Path] | None = None,
    judge: Judge | None = None,
    judge_for_trial: Callable[[int], Judge] | None = None,
    out_dir: str | Path | None = None,
    encoder=None,
    progress: Callable[[str], None] | None = None,
) -> EvalReport:
    """Evaluate text sets / run folders (diversity, feasibility, controllability) and edges.

    ``sources`` are file paths, run folders or ``example:<name>``; ``edges_file`` with ``judge``
    (or ``judge_for_trial``, a fresh judge per trial) adds edge-construction accuracy. ``out_dir`` receives ``eval.json`` and PNG plots.
    """
    settings = settings or EvalSettings()
    sources = list(sources or [])
    if not sources and edges_file is None:
        raise ConfigError("nothing to evaluate: give run folders or text sets, or an edge file")
    if edges_file is not None and judge is None and judge_for_trial is None:
        raise ConfigError("an edge file needs a judge (the model's edge construction)")
    say = progress or (lambda _msg: None)
    sets: list[TextSet] = load_text_sets(sources) if sources else []
    report = EvalReport(settings=settings, sources={s.name: s.source for s in sets})
    usable = {}
    for s in sets:
        if len(s.texts) < 2:
            report.skipped[s.name] = f"{len(s.texts)} text(s); diversity needs at least two"
        else:
            usable[s.name] = s.texts
    needs_encoder = settings.embeddings and (usable or any(s.run for s in sets))
    if needs_encoder and encoder is None:
        from regen.embeddings import default_encoder

        say("loading the embedding model")
        encoder = default_encoder()
    if usable:
        report.diversity = compare_sets(
            usable, n=settings.sample_size, repeats=settings.repeats, seed=settings.seed,
            embeddings=settings.embeddings, self_bleu_metric=settings.self_bleu,
            encoder=encoder, progress=lambda name: say(f"diversity of {name}"))
    runs = [s.run for s in sets if s.run is not None]
    if runs:
        say("feasibility and controllability")
        report.feasibility = feasibility_breakdown(runs)
        report.controllability = controllability(
            [sc for r in runs for sc in r.scenarios], encoder, embeddings=settings.embeddings)
    if edges_file is not None:
        examples = load_edge_examples(edges_file)
        report.edges = evaluate_edges(examples, judge, trials=settings.edge_trials,
                                      judge_for_trial=judge_for_trial,
                                      progress=lambda t: say(f"edge construction, trial {t + 1}"))
    if out_dir is not None:
        write_outputs(report, Path(out_dir))
    return report


def write_outputs(report: EvalReport, out_dir: Path) -> list[Path]:
    """Write the PNG plots that apply and ``eval.json`` (listing them) into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    if report.diversity:
        written.append(plots.diversity_plot(report.diversity, out_dir / "diversity.png"))
    if report.feasibility and report.feasibility.behaviors:
        written.append(plots.feasibility_plot(report.feasibility, out_dir / "feasibility.png"))
    if report.controllability and report.controllability.pairs:
        written.append(plots.controllability_histogram(report.controllability,
                                                       out_dir / "controllability.png"))
    if report.edges and report.edges.groups:
        written.append(plots.edges_plot(report.edges, out_dir / "edges.png"))
    json_path = out_dir / "eval.json"
    report.files = [str(p) for p in written] + [str(json_path)]
    write_json(json_path, report)
    return written + [json_path]
