"""``regen falsify RUN_DIR --policy SPEC --budget N``: a search over a run's causes for what makes
a policy fail. A thin layer over :func:`regen.falsify.search.run_falsify`; mounted by
:mod:`regen.cli` (``app.command("falsify")(falsify_command)``).

Exit code: 0 when the search finished (with or without findings: a search that finds nothing is
not an error), 2 for a bad RUN_DIR, SPEC, budget or folder, 130 when interrupted.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from regen.cli_help import REPLAY_HELP, llm_help
from regen.falsify.record import CANDIDATES, FALSIFY_JSON, CandidateRecord, Falsification
from regen.falsify.search import DEFAULT_PARAM_BUDGET, failure_words
from regen.harness.cli import OracleOption, PolicyOption, RunDirArgument, command_errors
from regen.pipeline.terminal import shown

_STYLE = {"PASS": "green", "FAIL": "red", "INVALID": "yellow", "ERROR": "red"}
_TAG = {"passed": "PASS", "failed": "FAIL", "invalid": "INVALID", "error": "ERROR"}

BudgetOption = Annotated[int, typer.Option(
    "--budget", "-n", min=1, help="Candidates to ground, simulate and test at most (single edits first, "
                                  "then pairs)")]
LlmOption = Annotated[str | None, typer.Option(
    "--llm", metavar="<model>", help=llm_help("that proposes new causes from the failures found (default: "
                                              "none, no model call)"), show_default=False)]
OutOption = Annotated[str | None, typer.Option(
    "--out", "-o", metavar="<folder>", help="Folder for falsify.json and the candidates (default: "
                                            "RUN_DIR/falsify/<policy>)", show_default=False)]
ParamBudgetOption = Annotated[int, typer.Option(
    "--param-budget", min=0, help="Parameter points searched per minimal finding (0: no parameter search)")]


def candidate_line(rec: CandidateRecord, n: int, budget: int) -> str:
    """One terminal line per candidate: PASS/FAIL/INVALID/ERROR, the edits in words, and why."""
    tag = _TAG[rec.status]
    why = failure_words(rec) if rec.status == "failed" else rec.reason
    if rec.status == "passed" and rec.policy is not None and rec.policy.min_ttc is not None:
        why = f"min TTC {rec.policy.min_ttc:.2f} s"
    kept = " (kept)" if rec.kept else ""
    model = " (model)" if rec.by_model else ""
    count = f"{n}/{budget}" if rec.simulated else "not simulated"
    return (f"[{_STYLE[tag]}]{tag}[/]  \\[{count}] {shown(rec.scenario)}: {shown('; '.join(rec.words))}{model}"
            f"{kept}  {shown(why)}")


def findings_table(report: Falsification) -> Table:
    """The findings as a rich table: the edits, how the policy failed, the scripted robot, minimal."""
    table = Table(title=f"{len(report.findings)} finding{'s' if len(report.findings) != 1 else ''} of "
                        f"{escape(report.policy)}", title_justify="left")
    for col in ("#", "scenario", "edits", "policy failure", f"scripted {report.robot}", "minimal", "candidate"):
        table.add_column(col, overflow="fold")
    for k, f in enumerate(report.findings, start=1):
        scripted = f.scripted.status + (f", {f.scripted.causal}" if f.scripted.causal else "")
        table.add_row(str(k), shown(f.scenario), shown("; ".join(f.edits)) + (" (model)" if f.by_model else ""),
                      shown(f.failure), shown(scripted), "yes" if f.minimal else "no", escape(Path(f.folder).name))
    return table


def falsify_command(
    run_dir: RunDirArgument,
    policy: PolicyOption = None,
    budget: BudgetOption = 24,
    llm: LlmOption = None,
    replay: Annotated[bool, typer.Option("--replay", help=REPLAY_HELP)] = False,
    out: OutOption = None,
    seed: Annotated[int, typer.Option(help="Added to each scenario's grounding seed (0: the scenario's own)")] = 0,
    oracle: OracleOption = "fsm",
    param_budget: ParamBudgetOption = DEFAULT_PARAM_BUDGET,
    pictures: Annotated[bool, typer.Option("--pictures/--no-pictures",
                                           help="Draw each candidate's GIF and each failure's; --no-pictures is "
                                                "faster")] = True,
) -> None:
    """Search a run's causes (set, remove, add) for what makes a policy fail where the scripted robot copes."""
    from regen.falsify.search import run_falsify
    from regen.harness.suite import open_suite
    from regen.promises.folders import out_folder

    console = Console(highlight=False, soft_wrap=True)
    err = Console(stderr=True, soft_wrap=True)
    with command_errors(err, run_dir, lambda: Path(out) if out is not None else None,
                        "the finished candidates are kept; run the same command again to continue"):
        dest = out_folder(out) if out is not None else None
        _, _, harness = open_suite(run_dir)
        policy = policy or next(iter(harness.builtin), "")
        report = run_falsify(run_dir, policy, budget=budget, out=dest, seed=seed, oracle=oracle,
                             make_llm=_model_maker(llm, replay),
                             pictures=pictures, param_budget=param_budget,
                             on_candidate=lambda rec, n: console.print(candidate_line(rec, n, budget)),
                             on_note=lambda note: err.print(f"[yellow]note:[/yellow] {shown(note)}"))
    _print_summary(console, report)
    _rerender(console, Path(run_dir), Path(report.out))


def _model_maker(llm: str | None, replay: bool) -> Callable[[Path], Any] | None:
    """``make_llm`` of :func:`regen.falsify.search.run_falsify`: the model ``--llm`` names, its
    answers cached beside falsify.json (None without ``--llm``: no model call)."""
    if llm is None:
        return None

    def make(folder: Path) -> Any:
        from regen.llm import LLM
        from regen.runfolder import RunFolder

        return LLM(llm, cache=str(folder / RunFolder.CACHE), replay=replay)

    return make


def _print_summary(console: Console, report: Falsification) -> None:
    if report.findings:
        console.print(findings_table(report))
        for k, f in enumerate(report.findings, start=1):
            console.print(f"  {k}. replay: {shown(f.replay)}")
    kept = f" ({report.kept} kept from an earlier run)" if report.kept else ""
    unsimulated = report.tried - report.simulated
    grounded = f"; {unsimulated} more could not be grounded (not counted)" if unsimulated else ""
    nf = len(report.findings)
    console.print(f"{report.simulated}/{report.budget} candidates simulated{kept}: {report.failures} failing, "
                  f"{report.invalid - unsimulated} invalid (the scripted {shown(report.robot)} did not verify or "
                  f"collided), {report.errors} could not run{grounded}; {nf} finding{'s' if nf != 1 else ''}; "
                  f"search {report.timings.get('search', report.wall):.0f} s")
    if report.parameter_search:
        took = report.timings.get("parameters")
        ran = took is not None and not report.parameter_search.startswith("parameter search not run")
        console.print(shown(report.parameter_search) + (f" in {took:.0f} s" if ran else ""))
    n = len(report.candidates)
    console.print(f"wrote {shown(str(Path(report.out) / FALSIFY_JSON))} and {n} candidate folder{'s' if n != 1 else ''} "
                  f"under {shown(str(Path(report.out) / CANDIDATES))}")


def _rerender(console: Console, run_dir: Path, dest: Path) -> None:
    """Rewrite RUN_DIR/report.html so it shows the search (``regen test``'s own way)."""
    from regen.harness.cli import rerender_report
    from regen.runfolder import RunFolder

    console.print(rerender_report(run_dir, dest, RunFolder.FALSIFY, "the searches", "not this one"))


def make_app() -> typer.Typer:
    """A standalone Typer app with only ``falsify`` (for tests)."""
    app = typer.Typer(add_completion=False)
    app.command("falsify")(falsify_command)
    return app


__all__ = ["candidate_line", "falsify_command", "findings_table", "make_app"]
