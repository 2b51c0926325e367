"""``regen dataset RUN_DIR... --out DIR``: a vision-language-action dataset from finished run
folders (a thin layer over :func:`regen.dataset.build_dataset`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

import typer
from rich.console import Console

from regen.errors import ConfigError
from regen.pipeline.terminal import shown

console = Console(highlight=False, soft_wrap=True)
err_console = Console(stderr=True, soft_wrap=True)


def dataset_command(
    runs: list[str] = typer.Argument(..., metavar="RUN_DIR", help="Finished driving run folders (the --out "
                                     "of regen generate, or the run folders inside a regen batch folder)"),
    out: str = typer.Option(..., "--out", "-o", metavar="<folder>", help="The dataset folder: samples.parquet, "
                            "qa.parquet, images/ and README.md (replaced when it holds an earlier dataset)"),
    fmt: list[str] = typer.Option(["parquet"], "--format", metavar="parquet|llava|lerobot", help="parquet: "
                                  "the tables (always written); llava: also llava.json, LLaVA-style "
                                  "conversations (repeatable); lerobot: manipulation runs as robot-learning "
                                  "episodes in the LeRobot v3 layout (alone)"),
    variants: bool = typer.Option(True, "--variants/--no-variants", help="Also simulate the test variants "
                                  "regen test recorded in the runs (about a second each)"),
    log: str = typer.Option("rich", "--log", help="Progress on stderr: rich, quiet, or jsonl (the events on "
                            "stdout)"),
) -> None:
    """A vision-language-action dataset from run folders: three frames at the ego's decision
    moment, the privileged state, the desired action, its explanation and computed QA layers."""
    from regen.dataset.samples import run_folder
    from regen.dataset.write import build_dataset
    from regen.progress import make_progress
    from regen.promises.folders import out_folder

    out_dir = out_folder(out)
    if log not in ("rich", "quiet", "jsonl"):
        raise ConfigError(f"--log must be rich, quiet or jsonl, not {log!r}")
    if "lerobot" in fmt:
        _episodes(runs, out_dir, fmt)
        return
    for run in runs:  # a folder that is not a run is told before any progress line
        run_folder(run)
    with make_progress(log, console=err_console, out=console) as progress:
        result = build_dataset(runs, out_dir, formats=tuple(dict.fromkeys(fmt)), variants=variants,
                               on_event=progress.on_event)
    if log == "jsonl":
        return
    console.print(f"{result.samples} samples, {result.qa} question-answer pairs, "
                  f"{len(result.skipped)} left out" + (": " + ", ".join(
                      f"{n} {shown(k)}" for k, n in sorted(result.left_out.items())) if result.skipped else ""))
    if result.camera_note:
        console.print(f"no camera pictures: {shown(result.camera_note)}")
    console.print(f"dataset: {shown(str(out_dir))} ({', '.join(result.files)})")


def _episodes(runs: list[str], out_dir, fmt: list[str]) -> None:
    """``--format lerobot``: the runs' domain writes its episodes (one domain per dataset)."""
    from pathlib import Path

    from regen import domains
    from regen.dataset.samples import run_folder

    if set(fmt) != {"lerobot"}:
        raise ConfigError("--format lerobot is written alone (its own folder layout): drop --format "
                          f"{', '.join(f for f in fmt if f != 'lerobot')} or write those to another --out")
    if not runs:
        raise ConfigError("give at least one run folder (RUN_DIR)")
    domain = run_folder(runs[0], domain="manipulation").read_manifest().behavior.domain
    folders = [run_folder(r, domain=domain).path for r in runs]
    got = domains.make(domain).write_episodes([Path(f) for f in folders], out_dir)
    console.print(f"{got.get('episodes', 0)} episodes, {got.get('frames', 0)} frames at {got.get('fps')} fps, "
                  f"{len(got.get('skipped') or [])} scenarios left out" + (
                      ": " + "; ".join(shown(str(s)) for s in got["skipped"]) if got.get("skipped") else ""))
    for names in got.get("same_motion") or []:
        console.print(f"same motion in {len(names)} episodes ({', '.join(shown(n) for n in names)}): the same "
                      "states, actions and pictures; their contexts differ only in words the simulation does "
                      "not show (as training data, duplicates)")
    console.print(f"LeRobot v3 dataset: {shown(str(out_dir))} (meta/info.json, meta/tasks.parquet, "
                  "meta/episodes/, data/)")
    if (got.get("check") or {}).get("note"):
        console.print(shown(str(got["check"]["note"])))


__all__ = ["dataset_command"]
