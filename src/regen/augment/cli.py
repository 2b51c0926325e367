"""``regen augment SCENARIO_DIR``: the model proposes causes to add to a scene and entities of it
that do not matter; each is simulated and verified (a thin layer over
:func:`regen.augment.run_augment`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from rich.console import Console

from regen.cli_help import llm_help
from regen.pipeline.terminal import shown
from regen.promises.folders import output_folder, run_of
from regen.runfolder import RunFolder
from regen.whatif import cli_args

console = Console(highlight=False, soft_wrap=True)
LLM_HELP = llm_help("that proposes and judges the causes (unless --no-judge)")
OutOption = cli_args.out_option("Folder for augment.json and augment.html (default: RUN/augment of the "
                                "scenario's run; needed for a scenario folder that is not inside a run)")
LlmOption = cli_args.llm_option(LLM_HELP)
PicturesOption = cli_args.pictures_option("Draw each counterfactual's GIF; --no-pictures is faster")
JudgeOption = cli_args.judge_option("Also ask the model whether each added cause causes the behavior; "
                                    "recorded beside the simulation's answer, which decides")

def augment_command(
    scenario_dir: cli_args.ScenarioDirArgument,
    out: OutOption = None,
    llm: LlmOption = "local",
    replay: cli_args.ReplayOption = False,
    pictures: PicturesOption = True,
    judge: JudgeOption = True,
) -> None:
    """Augment a scene: causes that would add to the behavior, entities that do not matter, each tested."""
    from regen.augment import run_augment
    from regen.llm import LLM

    src = cli_args.scenario_folder(scenario_dir)
    run = run_of(src, manifest=RunFolder.MANIFEST, scenarios=RunFolder.SCENARIOS)
    dest_root = cli_args.destination(src, out, RunFolder.AUGMENT, writes="augment.json")
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
        cli_args.refresh_report(run, console)


__all__ = ["augment_command"]
