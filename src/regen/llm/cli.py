"""``regen model status|prepare|verify``: the offline model's files (a thin layer over
:mod:`regen.llm.model_files`). Mounted by :mod:`regen.cli` under ``regen model``."""

from __future__ import annotations

import typer
from rich.console import Console

# soft wrap: a path is printed whole on one line, in a terminal or a CI log
console = Console(highlight=False, soft_wrap=True)
err_console = Console(stderr=True, highlight=False, soft_wrap=True)
DEFAULT_MODEL = "qwen2.5-coder-1.5b"
ModelArgument = typer.Argument(DEFAULT_MODEL, metavar="MODEL", help="The offline model's alias")


def model_status() -> None:
    """Which offline models are installed, joined and verified."""
    from regen.llm.model_files import MODELS, ModelFileError, stamp_ok
    from regen.paths import cache_dir

    for spec in MODELS.values():
        target = cache_dir("models") / spec.filename
        try:
            spec.part_paths()
            installed = "installed"
        except ModelFileError:
            installed = "not installed"
        joined = ("joined, verified" if target.exists() and stamp_ok(target, spec.sha256)
                  else "joined, not verified" if target.exists() else "not joined")
        console.print(f"{spec.alias}: {spec.description}; chunks {installed}; {joined} ({target})", markup=False)


def model_prepare(alias: str = ModelArgument) -> None:
    """Join and verify an offline model now (otherwise done on first use)."""
    from rich.progress import BarColumn, DownloadColumn, Progress

    from regen.llm.model_files import ensure_model

    live = err_console.is_terminal and not err_console.is_dumb_terminal
    if not live:  # a CI log or a pipe: one plain line, no bar
        err_console.print(f"joining {alias}", markup=False)
    with Progress("[progress.description]{task.description}", BarColumn(), DownloadColumn(),
                  console=err_console, disable=not live) as progress:
        task = progress.add_task(f"joining {alias}", total=None)
        path = ensure_model(alias, progress=lambda done, total: progress.update(
            task, completed=done, total=total))
    console.print(f"ready: {path}", markup=False)


def model_verify(alias: str = ModelArgument) -> None:
    """Re-hash a joined model file against its pinned sha256."""
    from regen.llm.model_files import MODELS, ensure_model, verify

    path = ensure_model(alias)
    verify(path, MODELS[alias].sha256, force=True)
    console.print(f"sha256 ok: {path}", markup=False)


__all__ = ["model_prepare", "model_status", "model_verify"]
