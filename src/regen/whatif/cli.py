"""``regen whatif SCENARIO_DIR``: counterfactual edits of a scenario's cause chain, from the
command line (a thin layer over :func:`regen.whatif.run_whatif`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from regen.cli_help import llm_help
from regen.errors import ConfigError
from regen.pipeline.terminal import shown
from regen.promises.folders import output_folder
from regen.runfolder import RunFolder
from regen.whatif import cli_args

console = Console(highlight=False, soft_wrap=True)


LLM_HELP = llm_help("that answers --ask and judges the cause (unless --no-judge)")
OutOption = cli_args.out_option("Folder for the counterfactual (default: RUN/whatif of the scenario's "
                                "run; needed for a scenario folder that is not inside a run)")
LlmOption = cli_args.llm_option(LLM_HELP)
PicturesOption = cli_args.pictures_option("Draw the counterfactual's GIF; --no-pictures is faster")
JudgeOption = cli_args.judge_option("Also ask the model (--llm) whether the edited cause still causes the "
                                    "behavior; its answer is recorded beside the simulation's (the but-for "
                                    "check with the reference robot), which decides")
NO_EDIT = "no edit: give --set ENTITY.PROPERTY=VALUE, --remove ENTITY, --add 'CAUSE' or --ask 'QUESTION'"


def llm_options(llm: str, cache: str, replay: bool):
    """The model client, caching beside the counterfactuals."""
    from regen.llm import LLM

    return LLM(llm, cache=cache, replay=replay)


def whatif_command(
    scenario_dir: cli_args.ScenarioDirArgument,
    set_: list[str] = typer.Option([], "--set", metavar="<entity.property=value>",
                                    help="Give a property of an entity of the chain another value, e.g. "
                                         "sedan1.brake_lights=broken (repeatable)"),
    remove: list[str] = typer.Option([], "--remove", metavar="<entity>",
                                     help="An entity of the cause chain that leaves the scene (repeatable)"),
    add: list[str] = typer.Option([], "--add", metavar="<cause>",
                                  help="A cause text that joins the chain, naming its entity, e.g. 'a cyclist "
                                       "rides ahead' (repeatable)"),
    ask: str | None = typer.Option(None, "--ask", metavar="<question>",
                                   help="A what-if question in words; the model answers with edits, which are "
                                        "shown and recorded"),
    out: OutOption = None,
    llm: LlmOption = "local",
    replay: cli_args.ReplayOption = False,
    pictures: PicturesOption = True,
    judge: JudgeOption = True,
) -> None:
    """Counterfactual what-if: edit a scenario's cause chain, then ground, simulate and verify it again."""
    from regen import whatif

    src = cli_args.scenario_folder(scenario_dir)
    edits = _edits_given(set_, remove, add)
    dest_root = cli_args.destination(src, out, RunFolder.WHATIF, writes="the counterfactual")
    if not edits and not ask:
        raise ConfigError(NO_EDIT)
    if edits:
        whatif.prepare(src, edits)  # a bad edit is told before any model loads or any file is written
    output_folder(dest_root, given=out is not None, give="a folder for the counterfactual")
    by: str = "user"
    client = None
    if ask or judge:
        client = llm_options(llm, str(dest_root / RunFolder.CACHE), replay)
    if ask:
        edits += _edits_asked(src, ask, client)
        by = "model"
    if not edits:
        raise ConfigError(NO_EDIT)
    with console.status("grounding, simulating and verifying the counterfactual"):
        dest, record = whatif.run_whatif(src, edits, dest_root, question=ask, edits_by=by,  # type: ignore[arg-type]
                                         pictures=pictures, judge=client if judge else None)
    _print_record(record, dest)
    run = dest.parent.parent
    if dest.parent.name == RunFolder.WHATIF and (run / RunFolder.MANIFEST).is_file():  # the report shows the pair
        cli_args.refresh_report(run, console)


def _edits_given(set_: list[str], remove: list[str], add: list[str]) -> list:
    """The edits of --set, --remove and --add, in that order."""
    from regen import whatif

    edits = [whatif.parse_set(s) for s in set_]
    edits += [whatif.Edit(op="remove", entity=e.strip()) for e in remove]
    edits += [whatif.Edit(op="add", text=t.strip()) for t in add]
    return edits


def _edits_asked(src: Path, ask: str, client) -> list:
    """The edits the model answers the --ask question with (shown as they come)."""
    from regen import domains, whatif
    from regen.runfolder import ScenarioFolder

    scenario = ScenarioFolder(src).scenario()
    if scenario is None:
        raise ConfigError(f"{src / ScenarioFolder.SCENARIO} cannot be read")
    asked = whatif.ask_edits(scenario, ask, client, domains.make(scenario.domain).database())
    console.print("the model's edits: " + "; ".join(shown(e.describe()) for e in asked))
    return asked


def _status(st: str, causal: str | None) -> str:
    return f"{st}, {causal}" if causal else st


def _print_record(record, dest: Path) -> None:
    """The counterfactual's edits, verdict beside the original's, judge and changed stages."""
    for e in record.edits:
        console.print(f"  {shown(e.describe())}")
    state = "[green]still explained[/]" if record.explained else "[red]no longer explained[/]"
    console.print(f"original: {_status(record.original_status, record.original_causal)}; counterfactual: "
                  f"{_status(record.status, record.causal)}: the behavior is {state}")
    console.print(f"  {shown(record.reason)}")
    if record.judged.get("by") != "none":
        plausible = "a plausible cause" if record.judged.get("plausible") else "no cause"
        console.print(f"  judged by {shown(str(record.judged['by']))}: {plausible} of what follows it")
    for c in record.stages_changed:
        console.print(f"  stage {c['index']}: {shown(c['before'] or '—')} -> {shown(c['after'] or '—')}")
    console.print(f"wrote {shown(str(dest))} (whatif.json, whatif.html)")


__all__ = ["whatif_command"]
