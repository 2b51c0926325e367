"""``regen eval``: a thin command over ``regen.evaluation.evaluate``.

Mount it in the main app with ``app.command("eval")(eval_command)``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from regen.cli_help import llm_help
from regen.errors import ConfigError, RegenError
from regen.evaluation.edges import bundled_edge_examples, model_judge
from regen.evaluation.evaluate import EvalSettings, evaluate
from regen.evaluation.tables import print_report
from regen.evaluation.textsets import EXAMPLE_PREFIX, bundled_sets
from regen.pipeline.terminal import shown
from regen.promises.folders import out_folder, output_folder
from regen.promises.secrets import redact


def _exit(exc: RegenError) -> typer.Exit:
    """Print ``exc`` as the one line ``error: ...`` (redacted of every key, escaped) and return
    the exit to raise."""
    Console(stderr=True, soft_wrap=True).print(f"[red]error:[/red] {shown(redact(str(exc), credentials=False))}")
    return typer.Exit(code=exc.exit_code)


def eval_command(
    sources: Annotated[list[str] | None, typer.Argument(
        metavar="SOURCE",
        help="Run folders, text sets (.txt one per line, .json, .jsonl) or example:<name> "
             "(bundled sets; see --list-examples). Each is one column of the comparison",
        show_default=False)] = None,
    out_text: Annotated[str | None, typer.Option(
        "--out", "-o", metavar="<folder>", help="Folder for eval.json and the PNG plots (with --fidelity: "
                                                "the runs of every case)", show_default=False)] = None,
    sample_size: Annotated[int | None, typer.Option(
        "--n", help="Texts drawn per repeat; default: the smallest set size")] = None,
    repeats: Annotated[int, typer.Option(help="Draws per set (the paper uses 10)")] = 10,
    seed: Annotated[int, typer.Option(help="Random seed of the draws")] = 0,
    embeddings: Annotated[bool, typer.Option(
        help="Embedding diversity with all-MiniLM-L6-v2 (needs the eval extra)")] = True,
    self_bleu: Annotated[bool, typer.Option("--self-bleu/--no-self-bleu",
                                            help="Self-BLEU diversity")] = True,
    edges: Annotated[str | None, typer.Option(
        metavar="<file>", help="Labeled edge file (JSON lines) for edge-construction accuracy; 'example' "
                               "uses the bundled one")] = None,
    llm: Annotated[str, typer.Option(metavar="<model>", help=llm_help("for --edges and --fidelity"))] = "local",
    trials: Annotated[int, typer.Option(help="Edge-construction trials")] = 5,
    list_examples: Annotated[bool, typer.Option(
        "--list-examples", help="List the bundled example text sets and exit")] = False,
    fidelity: Annotated[str | None, typer.Option(
        "--fidelity", metavar="<file>",
        help="Labeled cause texts (JSON lines, or 'driving' / 'manipulation' for the "
             "bundled sets): runs each insisted cause through the main job with --llm "
             "into --out (resumable) and reports entity and key-state accuracy and "
             "verified-but-unfaithful scenarios, per split")] = None,
    coverage: Annotated[bool, typer.Option(
        "--coverage",
        help="Typology coverage of the SOURCE run folders (or batch and falsify folders): per behavior, "
             "which NHTSA pre-crash classes (driving) their verified scenarios show, how often, and "
             "which not; with --out, coverage.json and coverage.png (docs/coverage.md)")] = False,
) -> None:
    """Diversity (embedding and Self-BLEU), feasibility, controllability, edge accuracy, entity
    fidelity and typology coverage."""
    console = Console(soft_wrap=True)  # a path is printed whole on one line, in a terminal or a CI log
    try:  # typer would turn an empty --out into Path(""), the current folder
        out = None if out_text is None else out_folder(out_text)
        if out is not None and not list_examples:  # a file in its place is told before any work
            output_folder(out, give="a folder for " + ("the fidelity runs" if fidelity is not None
                                                       else "coverage.json and coverage.png" if coverage
                                                       else "eval.json and the plots"))
    except RegenError as exc:
        raise _exit(exc) from None
    if coverage:
        _coverage(sources or [], out, console)
        return
    if fidelity is not None:
        _fidelity(fidelity, out, llm, console)
        return
    if list_examples:
        for name, about in bundled_sets().items():
            console.print(f"{EXAMPLE_PREFIX}{name}\t{about}")
        return
    try:
        judge_for_trial = None
        edges_file = None
        if edges is not None:
            edges_file = bundled_edge_examples() if edges == "example" else Path(edges)
            from regen.llm import LLM  # the LLM layer is only needed for edges

            model_judge(LLM(llm))  # fail early (missing key, missing package) before any work

            def judge_for_trial(_trial: int):
                # a fresh client per trial: no answers cached from earlier trials
                return model_judge(LLM(llm))
        settings = EvalSettings(sample_size=sample_size, repeats=repeats, seed=seed,
                                embeddings=embeddings, self_bleu=self_bleu, edge_trials=trials)
        with console.status("evaluating") as status:
            report = evaluate(sources or [], settings=settings, edges_file=edges_file,
                              judge_for_trial=judge_for_trial, out_dir=out,
                              progress=lambda msg: status.update(msg))
    except RegenError as exc:
        raise _exit(exc) from None
    print_report(report, console)


def _fidelity(source: str, out: Path | None, llm: str, console: Console) -> None:
    from rich.table import Table

    from regen.evaluation.fidelity import evaluate_fidelity, table
    from regen.evaluation.fidelity_set import load_cases

    if out is None:
        raise _exit(ConfigError("--fidelity needs --out FOLDER (the runs of every case go there; "
                                "rerunning resumes)"))
    try:
        cases = load_cases(source)
        with console.status("fidelity") as status:
            results = evaluate_fidelity(
                cases, out, llm=llm, progress=lambda msg: status.update(shown(msg)),
                note=lambda msg: Console(stderr=True, soft_wrap=True).print(
                    f"[yellow]note:[/yellow] {shown(msg)}"))
    except RegenError as exc:
        raise _exit(exc) from None
    rows = table(results)
    t = Table(title=f"Entity fidelity ({len(results)} cases, model {escape(llm)})")
    for col in ("domain", "split", "cases", "entity acc.", "key-state acc.", "verified",
                "verified & unfaithful", "unfaithful verdicts", "verified & caused (of checked)"):
        t.add_column(col)
    for r in rows:
        state = "-" if r["state_accuracy"] is None else f"{r['state_accuracy']:.2f}"
        t.add_row(r["domain"], r["split"], str(r["cases"]), f"{r['entity_accuracy']:.2f}", state,
                  str(r["verified"]), str(r["verified_and_unfaithful"]), str(r["unfaithful_verdicts"]),
                  f"{r['verified_and_caused']} ({r['verified_causal_checked']})")
    console.print(t)
    (out / "fidelity_table.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    console.print(f"per case: {shown(out / 'fidelity.jsonl')}")


def _coverage(sources: list[str], out: Path | None, console: Console) -> None:
    from regen.evaluation.coverage import COVERAGE_JSON, COVERAGE_PNG, coverage, print_coverage

    if not sources:
        raise _exit(ConfigError("--coverage needs run folders: regen eval --coverage RUN [RUN...] "
                                "(a batch folder counts each of its runs)"))
    try:
        with console.status("coverage") as status:
            report = coverage(sources, out_dir=out, progress=lambda msg: status.update(shown(msg)))
    except RegenError as exc:
        raise _exit(exc) from None
    print_coverage(report, console)
    if not report.typologies:
        console.print("[yellow]no behavior of a domain with a scenario typology: nothing was counted[/yellow]")
    if out is not None:
        written = [f for f in (COVERAGE_JSON, COVERAGE_PNG) if (out / f).is_file()]
        console.print(f"wrote {', '.join(shown(out / f) for f in written)}")
    else:
        console.print("[dim]give --out FOLDER to write coverage.json and coverage.png[/dim]")


def make_app() -> typer.Typer:
    """A standalone Typer app with only ``eval`` (for tests and ``python -m``)."""
    app = typer.Typer(add_completion=False)
    app.command("eval")(eval_command)

    @app.callback()
    def _root() -> None:
        """regen evaluation."""

    return app


if __name__ == "__main__":
    make_app()()
