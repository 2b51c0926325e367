"""Terminal tables (rich) for an EvalReport."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table

from regen.evaluation.diversity import MetricSummary
from regen.evaluation.evaluate import EvalReport


def _fmt(m: MetricSummary | None) -> str:
    if m is None:
        return "-"
    return f"{m.mean:.4f}" if m.std < 1e-9 else f"{m.mean:.4f} ± {m.std:.4f}"


def print_report(report: EvalReport, console: Console | None = None,
                 max_scenarios: int = 50) -> None:
    """Print every section of ``report`` that has content."""
    console = console or Console()
    if report.diversity:
        first = report.diversity[0]
        t = Table(title=f"Diversity (n = {first.sample_size} per draw, {first.repeats} draws, "
                        f"seed {report.settings.seed}; mean ± std)")
        t.add_column("set")
        t.add_column("texts", justify="right")
        t.add_column("embedding diversity ↑", justify="right")
        t.add_column("Self-BLEU diversity ↑", justify="right")
        for r in report.diversity:
            t.add_row(r.name, str(r.size), _fmt(r.embedding_diversity),
                      _fmt(r.self_bleu_diversity))
        console.print(t)
    for name, why in report.skipped.items():
        console.print(f"[yellow]skipped {name}: {why}[/yellow]")
    if report.feasibility:
        f = report.feasibility
        t = Table(title="Feasibility per behavior")
        for col in ("behavior", "scenarios", "with verdict", "feasible", "success rate", "statuses"):
            t.add_column(col, justify="left" if col in ("behavior", "statuses") else "right")
        for b in [*f.behaviors, f.total]:
            rate = "n/a" if b.success_rate is None else f"{100 * b.success_rate:.0f} %"
            t.add_row(b.behavior, str(b.scenarios), str(b.evaluated), str(b.feasible), rate,
                      ", ".join(f"{k}: {v}" for k, v in b.statuses.items()))
        console.print(t)
        t = Table(title="Feasibility per scenario")
        for col in ("behavior", "scenario", "causes", "feasible", "status / reason"):
            t.add_column(col)
        for s in f.scenarios[:max_scenarios]:
            mark = {True: "[green]yes[/green]", False: "[red]no[/red]", None: "-"}[s.feasible]
            why = s.status + (f": {s.reason}" if s.reason and not s.feasible else "")
            t.add_row(s.behavior, s.scenario, " <- ".join(reversed(s.causes)), mark, why)
        console.print(t)
        if len(f.scenarios) > max_scenarios:
            console.print(f"... {len(f.scenarios) - max_scenarios} more scenarios in eval.json")
    if report.controllability and report.controllability.pairs:
        c = report.controllability
        t = Table(title=f"Controllability ({len(c.pairs)} scenario pairs of the same behavior)")
        for col in ("pair group", "pairs", "share", "embedding diversity ↑"):
            t.add_column(col, justify="left" if col == "pair group" else "right")
        for name, g in c.groups.items():
            div = "-" if g.diversity_mean is None else f"{g.diversity_mean:.4f} ± {g.diversity_std:.4f}"
            t.add_row(name, str(g.pairs), f"{100 * g.share:.0f} %", div)
        console.print(t)
        if c.correlation is not None:
            console.print(f"correlation of cause difference and embedding diversity: "
                          f"{c.correlation:.3f}")
    if report.edges:
        e = report.edges
        t = Table(title=f"Edge construction (mean ± std over {e.trials} trials)")
        for col in ("edge", "domain", "split", "examples", "accuracy", "precision", "recall", "F1"):
            t.add_column(col, justify="left" if col in ("edge", "domain", "split") else "right")
        for g in e.groups:
            cells = [f"{s.mean:.2f} ± {s.std:.2f}" for s in (g.accuracy, g.precision, g.recall, g.f1)]
            t.add_row(g.kind, g.domain, g.split, str(g.examples), *cells)
        console.print(t)
        if any(g.split == "tune" for g in e.groups):
            console.print("tune: rows prompt work may look at; test: rows it never looks at (report these)")
        failed = sum(g.failed_calls for g in e.groups)
        if failed:
            console.print(f"[yellow]{failed} edge-construction calls failed and counted as "
                          "accepting nothing[/yellow]")
    for path in report.files:
        console.print(f"wrote {path}")
