"""``regen import FILE --out RUN``: a scenario file another tool wrote (OpenSCENARIO for driving),
simulated and verified with the main job's stages (a thin layer over
:func:`regen.pipeline.imports.import_file`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape

from regen.cli_help import DOMAIN_METAVAR, FOLDER_METAVAR, FRESH_HELP, PICTURES_HELP, RUN_OUT_HELP

console = Console(highlight=False, soft_wrap=True)
err_console = Console(stderr=True, highlight=False, soft_wrap=True)


def import_command(
    file: str = typer.Argument(..., metavar="FILE", help="The scenario file, e.g. scenario.xosc (its .xodr map "
                               "beside it)"),
    out: str = typer.Option(..., "--out", "-o", metavar=FOLDER_METAVAR, help=RUN_OUT_HELP),
    domain: str = typer.Option(None, "--domain", "-d", metavar=DOMAIN_METAVAR, help="The robot's domain, which "
                               "reads the file (default: by its suffix)"),
    pictures: bool = typer.Option(True, "--pictures/--no-pictures", help=PICTURES_HELP),
    fresh: bool = typer.Option(False, "--fresh", help=FRESH_HELP),
) -> None:
    """Import a scenario file: read its storyboard, derive the FSM, simulate and verify it."""
    from regen import domains
    from regen.pipeline.imports import import_file
    from regen.pipeline.terminal import print_outcomes, shown
    from regen.promises.folders import out_folder

    out_dir = out_folder(out)
    with console.status(f"importing {escape(Path(file).name)}") as status:
        def on_event(ev: dict) -> None:
            if ev["event"] == "simulating":
                status.update(f"simulating and verifying {escape(str(ev['name']))}")

        try:
            result = import_file(Path(file), out_dir, domain=domain, pictures=pictures, fresh=fresh,
                                 on_event=on_event)
        except KeyboardInterrupt:
            err_console.print(f"[yellow]interrupted; run the same command again to resume ({escape(out)})[/]")
            raise typer.Exit(130) from None
    scenario = result.outcomes[0].scenario()
    if scenario is not None:  # the file's own text: shown escaped, on one line each
        console.print(f"[bold]{shown(scenario.narrative)}[/]")
        importer = domains.make(scenario.domain).importer()
        for note in importer.notes(scenario) if importer is not None else []:
            console.print(f"  note: {shown(note)}")
    print_outcomes(console, result.outcomes, out_dir, indent="")
