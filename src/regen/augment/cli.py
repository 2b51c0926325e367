"""``regen augment SCENARIO_DIR``: the model proposes causes to add to a scene and entities of it
that do not matter; each is simulated and verified (a thin layer over
:func:`regen.augment.run_augment`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from regen.errors import ConfigError, RegenError
from regen.pipeline.terminal import shown
from regen.promises.folders import beside_run, out_folder, output_folder, run_of
from regen.runfolder import RunFolder

console = Console(highlight=False, soft_wrap=True)
LLM_HELP = ("Model that proposes (and judges, unless --no-judge): local (offline default), local:<alias or "
            ".gguf>, openai:<model>, anthropic:<model> (keys as for regen generate)")


def augment_command(
    scenario_dir: str = typer.Argument(..., help="A scenario folder of a run: RUN/scenarios/<name>"),
    out: str | None = typer.Option(None, "--out", "-o", help="Folder for augment.json and augment.html "
                                                             "(default: RUN/augment of the scenario's run; "
                                                             "needed for a scenario folder that is not inside "
                                                             "a run)"),
    llm: str = typer.Option("local", "--llm", help=LLM_HELP),
    replay: bool = typer.Option(False, "--replay", help="Forbid model calls: cached answers only"),
    pictures: bool = typer.Option(True, "--pictures/--no-pictures", help="Draw each counterfactual's GIF"),
    judge: bool = typer.Option(True, "--judge/--no-judge", help="Also ask the model whether each added cause "
                               "causes the behavior; recorded beside the simulation's answer, which decides"),
) -> None:
    """Augment a scene: causes that would add to the behavior, entities that do not matter, each tested."""
    from regen.augment import run_augment
    from regen.llm import LLM
    from regen.runfolder import ScenarioFolder

    src = Path(scenario_dir)
    if not (src / ScenarioFolder.SCENARIO).is_file():
        raise ConfigError(f"{src} holds no scenario.json: give a scenario folder, RUN/scenarios/<name>")
    where = {"manifest": RunFolder.MANIFEST, "scenarios": RunFolder.SCENARIOS}
    run = run_of(src, **where)
    # outside a run there is no RUN/augment: the folder two levels up is anybody's
    dest_root = out_folder(out) if out is not None else beside_run(src, RunFolder.AUGMENT, **where,
                                                                   writes="augment.json")
    # the counterfactuals sit with the run's what-ifs (the report shows them), else beside augment.json
    whatifs = run / RunFolder.WHATIF if out is None and run is not None else dest_root
    output_folder(dest_root, given=out is not None, give="a folder for augment.json and augment.html")
    client = LLM(llm, cache=str(dest_root / RunFolder.CACHE), replay=replay)
    with console.status("asking the model, then simulating each proposal") as status:
        dest, record = run_augment(src, dest_root, client, judge=client if judge else None, pictures=pictures,
                                   whatif_root=whatifs, on_step=lambda s: status.update(shown(s)))
    console.print(f"causes added ({len(record.additions)}):")
    for t in record.additions:
        mark = "[green]verified[/]" if t.holds else f"[red]{shown(t.status)}[/]"
        console.print(f"  {shown(t.proposal)}: {mark}: {shown(t.reason)}")
    console.print(f"entities claimed irrelevant ({len(record.irrelevant)}):")
    for t in record.irrelevant:
        mark = "[green]claim holds[/]" if t.holds else "[red]claim fails[/]"
        console.print(f"  {shown(t.proposal)} removed: {mark} ({shown(t.status)}): {shown(t.reason)}")
    if record.dropped:  # each name shown escaped: a model's line break cannot start a line of its own
        console.print(f"[yellow]not in the scene, ignored:[/] {', '.join(shown(n) for n in record.dropped)}")
    console.print(f"wrote {shown(str(dest))} (augment.json, augment.html)")
    if run is not None and whatifs == run / RunFolder.WHATIF:  # the run's report lists them
        from regen.report import write_report

        try:
            console.print(f"report: {shown(str(write_report(run)))}")
        except (RegenError, OSError) as exc:
            console.print(f"[yellow]report not updated:[/] {shown(str(exc))}")


__all__ = ["augment_command"]
