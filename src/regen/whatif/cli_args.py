"""What the commands that rework one scenario folder (``regen whatif``, ``regen augment``)
share on the command line: their options, the scenario folder they are given, where they write
(``--out``, else a folder of the scenario's run) and the run's report they bring up to date.

Each command words the help of ``--out``, ``--llm``, ``--pictures`` and ``--judge`` for what it
does; the names and defaults are the same everywhere."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console

from regen.cli_help import FOLDER_METAVAR, MODEL_METAVAR, REPLAY_HELP
from regen.errors import ConfigError, RegenError
from regen.pipeline.terminal import shown
from regen.promises.folders import beside_run, out_folder
from regen.runfolder import RunFolder, ScenarioFolder

ScenarioDirArgument = Annotated[str, typer.Argument(metavar="SCENARIO_DIR",
                                                    help="A scenario folder of a run: RUN/scenarios/<name>")]
ReplayOption = Annotated[bool, typer.Option("--replay", help=REPLAY_HELP)]

# the options each command words for itself: a command declares e.g. ``OutOption = out_option("...")``
# and its parameter ``out: OutOption = None`` (typer takes the default from ``=``)


def out_option(help: str) -> Any:
    """``--out``/``-o`` (a str, default None): the folder to write in, else one of the scenario's run."""
    return Annotated[str | None, typer.Option("--out", "-o", metavar=FOLDER_METAVAR, help=help)]


def llm_option(help: str) -> Any:
    """``--llm`` (a str, default 'local'): the model the command asks."""
    return Annotated[str, typer.Option("--llm", metavar=MODEL_METAVAR, help=help)]


def pictures_option(help: str) -> Any:
    """``--pictures/--no-pictures`` (default True)."""
    return Annotated[bool, typer.Option("--pictures/--no-pictures", help=help)]


def judge_option(help: str) -> Any:
    """``--judge/--no-judge`` (default True): the model judges the cause too."""
    return Annotated[bool, typer.Option("--judge/--no-judge", help=help)]


def scenario_folder(scenario_dir: str) -> Path:
    """The scenario folder given on the command line; ConfigError when it holds no scenario.json."""
    src = Path(scenario_dir)
    if not (src / ScenarioFolder.SCENARIO).is_file():
        raise ConfigError(f"{src} holds no scenario.json: give a scenario folder, RUN/scenarios/<name>")
    return src


def destination(src: Path, out: str | None, run_folder: str, *, writes: str) -> Path:
    """``--out``, else the folder ``run_folder`` of the scenario's run (outside a run there is none:
    the folder two levels up is anybody's, and ConfigError asks for ``--out``)."""
    if out is not None:
        return out_folder(out)
    return beside_run(src, run_folder, manifest=RunFolder.MANIFEST, scenarios=RunFolder.SCENARIOS, writes=writes)


def refresh_report(run: Path, console: Console) -> None:
    """Write the run's report again (it shows what the command added); a failure is told, not raised."""
    from regen.report import write_report

    try:
        console.print(f"report: {shown(str(write_report(run)))}")
    except (RegenError, OSError) as exc:
        console.print(f"[yellow]report not updated:[/] {shown(str(exc))}")


__all__ = ["ReplayOption", "ScenarioDirArgument", "destination", "judge_option", "llm_option", "out_option",
           "pictures_option", "refresh_report", "scenario_folder"]
