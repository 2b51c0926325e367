"""The ``regen`` command: a thin typer layer over library functions.

Errors the toolkit raises on purpose (:class:`regen.errors.RegenError`) are printed as one line
that says what to do, with no traceback.
"""

from __future__ import annotations

import functools
import json
import logging
from collections.abc import Callable
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from regen.errors import RegenError

F = TypeVar("F", bound=Callable[..., Any])

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="ReGen: infer simulated environments that explain a robot behavior.")
model_app = typer.Typer(no_args_is_help=True, help="The offline model: status, prepare, verify.")
app.add_typer(model_app, name="model")

console = Console()
err_console = Console(stderr=True, soft_wrap=True)


def friendly(fn: F) -> F:
    """Show RegenError as a one-line message and exit with its code."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except RegenError as exc:
            err_console.print(f"[bold red]error:[/] {escape(str(exc))}")
            raise typer.Exit(exc.exit_code) from None

    return wrapper  # type: ignore[return-value]


@app.callback()
def _root(verbose: bool = typer.Option(False, "--verbose", "-v", help="Log details to stderr.")) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")


@app.command("assets")
@friendly
def assets_cmd(domain: str = typer.Argument(..., help="driving, manipulation, or a database JSON file"),
               as_json: bool = typer.Option(False, "--json", help="Print the database as JSON.")) -> None:
    """Show what a simulator's asset database can simulate."""
    from regen.assets import load_database

    db = load_database(domain)
    if as_json:
        console.print_json(db.model_dump_json())
        return
    table = Table(title=f"{db.name} assets ({db.simulator})")
    for col in ("category", "asset", "properties", "behaviors"):
        table.add_column(col)
    for cat, members in db.categories.items():
        for a in members:
            spec = db.assets[a]
            table.add_row(cat, a, ", ".join(spec.properties), ", ".join(spec.behaviors))
    console.print(table)


@app.command("predicates")
@friendly
def predicates_cmd(domain: str = typer.Argument(None, help="driving or manipulation (default: all)")) -> None:
    """List the predicate library that abstract states are built from."""
    from regen.verify import list_predicates

    table = Table(title="predicate library")
    for col in ("signature", "domains", "meaning"):
        table.add_column(col)
    for spec in list_predicates(domain):
        table.add_row(escape(spec.signature()), ", ".join(spec.domains), escape(spec.doc))
    console.print(table)


@model_app.command("status")
@friendly
def model_status() -> None:
    """Which offline models are installed, joined and verified."""
    from regen.llm.model_files import MODELS, ModelFileError, _stamp_ok
    from regen.paths import cache_dir

    for spec in MODELS.values():
        target = cache_dir("models") / spec.filename
        try:
            spec.part_paths()
            installed = "installed"
        except ModelFileError:
            installed = "not installed"
        joined = ("joined, verified" if target.exists() and _stamp_ok(target, spec.sha256)
                  else "joined, not verified" if target.exists() else "not joined")
        console.print(f"{spec.alias}: {spec.description}; chunks {installed}; {joined} ({target})")


@model_app.command("prepare")
@friendly
def model_prepare(alias: str = typer.Argument("qwen2.5-coder-1.5b")) -> None:
    """Join and verify an offline model now (otherwise done on first use)."""
    from rich.progress import BarColumn, DownloadColumn, Progress

    from regen.llm.model_files import ensure_model

    with Progress("[progress.description]{task.description}", BarColumn(), DownloadColumn(),
                  console=err_console) as progress:
        task = progress.add_task(f"joining {alias}", total=None)
        path = ensure_model(alias, progress=lambda done, total: progress.update(
            task, completed=done, total=total))
    console.print(f"ready: {path}")


@model_app.command("verify")
@friendly
def model_verify(alias: str = typer.Argument("qwen2.5-coder-1.5b")) -> None:
    """Re-hash a joined model file against its pinned sha256."""
    from regen.llm.model_files import MODELS, ensure_model, verify

    path = ensure_model(alias)
    verify(path, MODELS[alias].sha256, force=True)
    console.print(f"sha256 ok: {path}")


def print_json(value: Any) -> None:
    console.print_json(json.dumps(value, default=str))


def main() -> None:
    app()


if __name__ == "__main__":
    main()
