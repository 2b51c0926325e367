"""The terminal lines of a run's outcomes, shared by ``regen generate`` and ``regen import``.

Imports: rich, and the pipeline's own outcome type and the verdict's causal part (annotations only).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from rich.markup import escape

if TYPE_CHECKING:
    from rich.console import Console

    from regen.core.verdict import Causal
    from regen.pipeline.stages import ScenarioOutcome


def causal_mark(causal: Causal | None) -> str:
    """The causal part of a verdict as rich markup ('' when it has none): 'caused' in green,
    'confounded (traffic_light1)' and the other findings in yellow, 'not_checked' dim."""
    if causal is None:
        return ""
    text = causal.status + (f" ({', '.join(causal.confounders)})" if causal.confounders else "")
    colour = {"caused": "green", "not_checked": "dim"}.get(causal.status, "yellow")
    return f"[{colour}]{escape(text)}[/]"


def print_outcomes(console: Console, outcomes: Sequence[ScenarioOutcome], out_dir: Path, *,
                   indent: str = "  ") -> None:
    """One line per scenario (its folder, its verdict in colour with the causal check beside
    it, the reason), the causal check's reason below when the cause was not found to cause the
    behavior, then the report's path."""
    for o in outcomes:
        v = o.verdict
        mark = f"[green]{v.status}[/]" if v.feasible else f"[red]{v.status}[/]"
        causal = v.causal  # None: a verdict written before the check existed
        if causal is not None:
            mark += f", {causal_mark(causal)}"
        console.print(f"{indent}{escape(o.folder)}: {mark}: {escape(v.reason)}")
        if causal is not None and causal.status != "caused" and causal.reason:
            console.print(f"{indent}    cause: {escape(causal.reason)}")
    report = out_dir / "report.html"
    if report.exists():
        console.print(f"report: {report}")
