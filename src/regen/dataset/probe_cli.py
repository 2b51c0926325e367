"""``regen probe DATASET --llm PROVIDER``: ask a model each question of a dataset and score it
against the simulation's answer (a thin layer over :func:`regen.dataset.probe.probe_dataset`).
Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from regen.cli_help import FOLDER_METAVAR, MODEL_METAVAR, REPLAY_HELP, llm_help
from regen.dataset.qa import LAYERS
from regen.errors import ConfigError
from regen.pipeline.terminal import shown

console = Console(highlight=False, soft_wrap=True)
err_console = Console(stderr=True, soft_wrap=True)


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


def probe_command(
    dataset: str = typer.Argument(..., metavar="DATASET", help="A dataset folder (the --out of regen dataset)"),
    llm: str = typer.Option("local", "--llm", metavar=MODEL_METAVAR, help=llm_help("that answers the questions")),
    text_only: bool = typer.Option(False, "--text-only", help="Show no pictures: ask with the privileged "
                                   "information as text (always so for a model that reads no images)"),
    privileged: bool = typer.Option(False, "--privileged", help="Also give every entity's per-frame state "
                                    "(pose, speed, size, recorded states) as text beside the pictures"),
    layers: str = typer.Option(",".join(LAYERS), "--layers", metavar="<layer,...>", help="The question layers "
                               "to ask, comma-separated: " + ", ".join(LAYERS)),
    out: str | None = typer.Option(None, "--out", "-o", metavar=FOLDER_METAVAR, help="Folder for probe.json, "
                                   "report.md, confusion_planning.png and the model cache (default: "
                                   "DATASET/probe-<provider>)"),
    limit: int | None = typer.Option(None, "--limit", metavar="<n>", min=1, help="Ask only the first n scored "
                                     "questions (in qa_id order)"),
    replay: bool = typer.Option(False, "--replay", help=REPLAY_HELP),
) -> None:
    """Ask a model each multiple-choice question of a dataset and score its answers against the
    simulation's: accuracy per layer, behavior and cause, the planning confusion matrix and the
    counterfactual flips."""
    from regen.dataset.probe import (
        CACHE,
        default_out,
        mode_for,
        parse_layers,
        probe_dataset,
        read_dataset,
    )
    from regen.llm import LLM

    chosen = parse_layers(layers)  # bad input is told before any model loads
    data = read_dataset(dataset)
    out_dir = Path(out) if out is not None else default_out(dataset, llm)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out} is a file; give a folder for the probe's results")
    out_dir.mkdir(parents=True, exist_ok=True)
    client = LLM(llm, cache=out_dir / CACHE, replay=replay)
    mode = mode_for(client.provider, text_only=text_only, privileged=privileged)
    if mode.note:
        console.print(mode.note)
    asked = sum(q.layer in chosen and q.key is not None for q in data.questions)
    asked = min(asked, limit) if limit is not None else asked
    what = f"asking {client.provider.id} {asked} questions"
    with err_console.status(what) as status:
        def progress(done: int, total: int, got) -> None:
            right = sum(r is True for r in tally) + (got.correct is True)
            tally.append(got.correct)
            line = f"{what}: {done}/{total} answered, {right} correct so far"
            if err_console.is_terminal:
                status.update(line)
            elif done == total or done % 10 == 0:  # a log gets a line every 10 answers
                err_console.print(line)

        tally: list[bool | None] = []
        result = probe_dataset(dataset, client, out=out_dir, text_only=text_only, privileged=privileged,
                               layers=chosen, limit=limit, on_answer=progress)
    sc = result.score
    assert sc is not None
    table = Table(title=f"probe of {shown(data.path.name)} with {shown(result.provider)} "
                        f"(asked with {result.mode.asked}{' + privileged' if result.mode.privileged else ''})")
    for col in ("group", "asked", "correct", "accuracy"):
        table.add_column(col, justify="left" if col == "group" else "right")
    table.add_row("overall", str(sc.overall.asked), str(sc.overall.correct), _pct(sc.overall.accuracy),
                  end_section=True)
    for kind, groups in (("layer", sc.by_layer), ("behavior", sc.by_behavior), ("cause", sc.by_cause)):
        for k, (name, t) in enumerate(groups.items()):
            table.add_row(f"{kind}: {shown(name)}", str(t.asked), str(t.correct), _pct(t.accuracy),
                          end_section=k == len(groups) - 1)
    console.print(table)
    f = sc.flips
    console.print(f"unscored (no single option): {sc.unscored}; not asked (--limit): {sc.not_asked}; "
                  f"no valid answer (counted wrong): {sc.no_answer}")
    console.print(f"counterfactual pairs: {f.pairs}; flips correct {f.correct}, flips wrong {f.wrong}, "
                  f"missed flips {f.missed} (flip rate {_pct(f.rate)})")
    console.print(f"results: {shown(str(out_dir))} ({', '.join(result.files)}); {client.stats.summary()}")


__all__ = ["probe_command"]
