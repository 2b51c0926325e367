"""PNG plots of the evaluation results (matplotlib, Agg backend, imported on use)."""

from __future__ import annotations

import textwrap
from pathlib import Path

from regen.evaluation.controllability import DIFFERENT_CAUSE, SAME_CAUSE, ControllabilityReport
from regen.evaluation.diversity import SetDiversity
from regen.evaluation.edges import EdgeReport
from regen.evaluation.feasibility import FeasibilityReport


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")  # no display; must precede the pyplot import
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    _pyplot().close(fig)
    return path


def diversity_plot(results: list[SetDiversity], path: str | Path) -> Path:
    """Side-by-side bars of embedding and Self-BLEU diversity (mean, std as error bars)."""
    plt = _pyplot()
    panels = [("embedding_diversity", "Embedding diversity (1 - mean cosine)"),
              ("self_bleu_diversity", "Self-BLEU diversity (1 - Self-BLEU)")]
    panels = [p for p in panels if any(getattr(r, p[0]) is not None for r in results)]
    names = [f"{r.name}\n(n={r.sample_size} of {r.size})" for r in results]
    fig, axes = plt.subplots(1, max(len(panels), 1), figsize=(5.5 * max(len(panels), 1),
                                                              1.2 + 0.55 * len(results)),
                             squeeze=False)
    for ax, (attr, title) in zip(axes[0], panels, strict=False):
        means = [getattr(r, attr).mean if getattr(r, attr) else 0.0 for r in results]
        stds = [getattr(r, attr).std if getattr(r, attr) else 0.0 for r in results]
        y = list(range(len(results)))
        ax.barh(y, means, xerr=stds, color="#4C72B0", capsize=4)
        for yi, m, s in zip(y, means, stds, strict=True):
            ax.text(m + s + 0.01, yi, f"{m:.3f}", va="center", fontsize=8)
        ax.set_yticks(y, names, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, max(1.0, max(m + s for m, s in zip(means, stds, strict=True)) + 0.1))
        ax.set_title(title, fontsize=10)
        ax.grid(axis="x", alpha=0.3)
    repeats = results[0].repeats if results else 0
    fig.suptitle(f"Diversity, mean ± std over {repeats} draws (higher is more diverse)", fontsize=10)
    return _save(fig, Path(path))


def controllability_histogram(report: ControllabilityReport, path: str | Path,
                              bins: int = 20) -> Path:
    """Histogram of pairwise text diversity, split into different-cause and same-cause pairs."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    colors = {DIFFERENT_CAUSE: "#DD8452", SAME_CAUSE: "#4C72B0"}
    have_div = any(p.diversity is not None for p in report.pairs)
    for group in (SAME_CAUSE, DIFFERENT_CAUSE):
        vals = [(p.diversity if have_div else p.cause_difference)
                for p in report.pairs if p.group == group]
        if have_div:
            vals = [v for v in vals if v is not None]
        stats = report.groups.get(group)
        share = f"{100 * stats.share:.0f} % of pairs" if stats else ""
        ax.hist(vals, bins=bins, range=(0.0, 1.0), alpha=0.65, color=colors[group],
                label=f"{group} ({len(vals)} pairs, {share})")
    ax.set_xlabel("pairwise embedding diversity (1 - cosine)" if have_div
                  else "cause difference (share of non-shared causes)")
    ax.set_ylabel("scenario pairs")
    ax.set_title("Controllability: pairwise diversity by cause", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    return _save(fig, Path(path))


def feasibility_plot(report: FeasibilityReport, path: str | Path) -> Path:
    """Success rate per behavior, annotated with feasible / evaluated counts."""
    plt = _pyplot()
    rows = report.behaviors
    fig, ax = plt.subplots(figsize=(7, 1.2 + 0.5 * max(len(rows), 1)))
    y = list(range(len(rows)))
    rates = [r.success_rate or 0.0 for r in rows]
    ax.barh(y, rates, color="#55A868")
    for yi, r in zip(y, rows, strict=True):
        rate = "n/a" if r.success_rate is None else f"{100 * r.success_rate:.0f} %"
        ax.text((r.success_rate or 0.0) + 0.01, yi, f"{rate} ({r.feasible}/{r.evaluated})",
                va="center", fontsize=8)
    ax.set_yticks(y, ["\n".join(textwrap.wrap(r.behavior, 40)) for r in rows], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0, 1.25)  # room for the labels right of a 100 % bar
    ax.set_xticks([0, 0.25, 0.5, 0.75, 1.0], ["0 %", "25 %", "50 %", "75 %", "100 %"])
    ax.set_xlabel("share of scenarios whose FSM reached its accepting stage")
    ax.set_title("Feasibility per behavior", fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    return _save(fig, Path(path))


def edges_plot(report: EdgeReport, path: str | Path) -> Path:
    """Grouped bars of accuracy, precision, recall and F1 per (domain, edge kind)."""
    plt = _pyplot()
    names = ["accuracy", "precision", "recall", "f1"]
    groups = report.groups
    fig, ax = plt.subplots(figsize=(1.6 + 1.6 * max(len(groups), 1), 4))
    width = 0.2
    for k, name in enumerate(names):
        xs = [i + (k - 1.5) * width for i in range(len(groups))]
        ax.bar(xs, [getattr(g, name).mean for g in groups], width,
               yerr=[getattr(g, name).std for g in groups], capsize=3, label=name)
    ax.set_xticks(range(len(groups)), [f"{g.kind}\n{g.domain}" for g in groups], fontsize=8)
    ax.set_ylim(0, 1.3)  # headroom for the legend above the bars
    ax.set_yticks([0, 0.2, 0.4, 0.6, 0.8, 1.0])
    ax.set_title(f"Edge construction, mean ± std over {report.trials} trials", fontsize=10)
    ax.legend(fontsize=8, ncol=4, loc="upper center")
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, Path(path))
