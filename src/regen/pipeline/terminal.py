"""The terminal lines of a run's outcomes, shared by ``regen generate`` and ``regen import``, and
:func:`shown`, how every command prints model, file or error text to a Rich console.

Imports: rich, :mod:`regen.promises.terminal`, and the pipeline's own outcome type and the
verdict's causal part (annotations only).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from rich.markup import escape

from regen.promises.terminal import printable

if TYPE_CHECKING:
    from rich.console import Console

    from regen.core.verdict import Causal
    from regen.pipeline.stages import ScenarioOutcome


def shown(value: object) -> str:
    """Model, file or error text for a Rich console: on one line, with every control, line-break
    (U+2028, U+2029 too), bidi and invisible character shown escaped
    (:func:`regen.promises.terminal.printable`) and Rich markup escaped ('box [/]' prints as
    written)."""
    return escape(printable(value))


def causal_mark(causal: Causal | None) -> str:
    """The causal part of a verdict as rich markup ('' when it has none): 'caused' in green,
    'confounded (traffic_light1)' and the other findings in yellow, 'not_checked' dim."""
    if causal is None:
        return ""
    text = causal.status + (f" ({', '.join(causal.confounders)})" if causal.confounders else "")
    colour = {"caused": "green", "not_checked": "dim"}.get(causal.status, "yellow")
    return f"[{colour}]{shown(text)}[/]"


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
        console.print(f"{indent}{shown(o.folder)}: {mark}: {shown(v.reason)}")
        if causal is not None and causal.status != "caused" and causal.reason:
            console.print(f"{indent}    cause: {shown(causal.reason)}")
    report = out_dir / "report.html"
    if report.exists():
        console.print(f"report: {shown(report)}")
