"""``regen whatif SCENARIO_DIR``: counterfactual edits of a scenario's cause chain, from the
command line (a thin layer over :func:`regen.whatif.run_whatif`). Mounted by :mod:`regen.cli`."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from regen.errors import ConfigError, RegenError
from regen.pipeline.terminal import shown
from regen.promises.folders import beside_run, out_folder, output_folder
from regen.runfolder import RunFolder

console = Console(highlight=False, soft_wrap=True)


LLM_HELP = ("Model for --ask and the judge: local (offline default), local:<alias or .gguf>, "
            "openai:<model>, anthropic:<model> (keys as for regen generate)")


def llm_options(llm: str, cache: str, replay: bool):
    """The model client, caching beside the counterfactuals."""
    from regen.llm import LLM

    return LLM(llm, cache=cache, replay=replay)


def whatif_command(
    scenario_dir: str = typer.Argument(..., help="A scenario folder of a run: RUN/scenarios/<name>"),
    set_: list[str] = typer.Option([], "--set", help="ENTITY.PROPERTY=VALUE, e.g. sedan1.brake_lights=broken "
                                                      "(repeatable)"),
    remove: list[str] = typer.Option([], "--remove", help="An entity of the cause chain that leaves the scene "
                                                         "(repeatable)"),
    add: list[str] = typer.Option([], "--add", help="A cause text that joins the chain, naming its entity, e.g. "
                                                   "'a cyclist rides ahead' (repeatable)"),
    ask: str | None = typer.Option(None, "--ask", help="A what-if question in words; the model answers with "
                                                       "edits, which are shown and recorded"),
    out: str | None = typer.Option(None, "--out", "-o", help="Folder for the counterfactual (default: "
                                                             "RUN/whatif of the scenario's run; needed for "
                                                             "a scenario folder that is not inside a run)"),
    llm: str = typer.Option("local", "--llm", help=LLM_HELP),
    replay: bool = typer.Option(False, "--replay", help="Forbid model calls: cached answers only"),
    pictures: bool = typer.Option(True, "--pictures/--no-pictures", help="Draw the counterfactual's GIF"),
    judge: bool = typer.Option(True, "--judge/--no-judge", help="Also ask the model (--llm) whether the edited "
                               "cause still causes the behavior; its answer is recorded beside the "
                               "simulation's (the but-for check with the reference robot), which decides"),
) -> None:
    """Counterfactual what-if: edit a scenario's cause chain, then ground, simulate and verify it again."""
    from regen import whatif
    from regen.runfolder import ScenarioFolder

    src = Path(scenario_dir)
    if not (src / ScenarioFolder.SCENARIO).is_file():
        raise ConfigError(f"{src} holds no scenario.json: give a scenario folder, RUN/scenarios/<name>")
    edits = [whatif.parse_set(s) for s in set_]
    edits += [whatif.Edit(op="remove", entity=e.strip()) for e in remove]
    edits += [whatif.Edit(op="add", text=t.strip()) for t in add]
    # outside a run there is no RUN/whatif: the folder two levels up is anybody's
    dest_root = out_folder(out) if out is not None else beside_run(
        src, RunFolder.WHATIF, manifest=RunFolder.MANIFEST, scenarios=RunFolder.SCENARIOS,
        writes="the counterfactual")
    if not edits and not ask:
        raise ConfigError("no edit: give --set ENTITY.PROPERTY=VALUE, --remove ENTITY, --add 'CAUSE' or --ask 'QUESTION'")
    if edits:
        whatif.prepare(src, edits)  # a bad edit is told before any model loads or any file is written
    output_folder(dest_root, given=out is not None, give="a folder for the counterfactual")
    by: str = "user"
    client = None
    if ask or judge:
        client = llm_options(llm, str(dest_root / RunFolder.CACHE), replay)
    if ask:
        from regen import domains

        scenario = ScenarioFolder(src).scenario()
        if scenario is None:
            raise ConfigError(f"{src / ScenarioFolder.SCENARIO} cannot be read")
        asked = whatif.ask_edits(scenario, ask, client, domains.make(scenario.domain).database())
        console.print("the model's edits: " + "; ".join(shown(e.describe()) for e in asked))
        edits += asked
        by = "model"
    if not edits:
        raise ConfigError("no edit: give --set ENTITY.PROPERTY=VALUE, --remove ENTITY, --add 'CAUSE' or --ask 'QUESTION'")
    with console.status("grounding, simulating and verifying the counterfactual"):
        dest, record = whatif.run_whatif(src, edits, dest_root, question=ask, edits_by=by,  # type: ignore[arg-type]
                                         pictures=pictures, judge=client if judge else None)
    for e in record.edits:
        console.print(f"  {shown(e.describe())}")
    state = "[green]still explained[/]" if record.explained else "[red]no longer explained[/]"
    def status(st: str, causal: str | None) -> str:
        return f"{st}, {causal}" if causal else st

    console.print(f"original: {status(record.original_status, record.original_causal)}; counterfactual: "
                  f"{status(record.status, record.causal)}: the behavior is {state}")
    console.print(f"  {shown(record.reason)}")
    if record.judged.get("by") != "none":
        plausible = "a plausible cause" if record.judged.get("plausible") else "no cause"
        console.print(f"  judged by {shown(str(record.judged['by']))}: {plausible} of what follows it")
    for c in record.stages_changed:
        console.print(f"  stage {c['index']}: {shown(c['before'] or '—')} -> {shown(c['after'] or '—')}")
    console.print(f"wrote {shown(str(dest))} (whatif.json, whatif.html)")
    run = dest.parent.parent
    if dest.parent.name == RunFolder.WHATIF and (run / RunFolder.MANIFEST).is_file():  # the report shows the pair
        from regen.report import write_report

        try:
            console.print(f"report: {shown(str(write_report(run)))}")
        except (RegenError, OSError) as exc:
            console.print(f"[yellow]report not updated:[/] {shown(str(exc))}")


__all__ = ["whatif_command"]
