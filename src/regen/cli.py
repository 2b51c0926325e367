"""The ``regen`` command: a thin typer layer over library functions.

Errors the toolkit raises on purpose (:class:`regen.errors.RegenError`) are printed as one line
that says what to do, with no traceback.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import json
import logging
import os
import re
from collections.abc import Callable, Iterator
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from regen import domains
from regen.cli_help import (
    CANDIDATE_HELP,
    CAUSE_HELP,
    DOMAIN_METAVAR,
    FOLDER_METAVAR,
    FRESH_HELP,
    LLM_HELP,
    LLM_TIMEOUT_HELP,
    MODEL_METAVAR,
    PICTURES_HELP,
    REPLAY_HELP,
    RUN_OUT_HELP,
    TRAJECTORY_HELP,
    group_help,
    help_for,
    package_version,
)
from regen.errors import RegenError
from regen.pipeline.terminal import shown
from regen.promises.secrets import RedactingFilter, redact

F = TypeVar("F", bound=Callable[..., Any])

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="ReGen: infer simulated environments that explain a robot behavior.", **group_help(""))
model_app = typer.Typer(no_args_is_help=True, help="The offline model: status, prepare, verify.",
                        **group_help("model"))
app.add_typer(model_app, name="model")

# soft wrap: a long line (a path above all) is never broken by a newline, in a terminal or a CI log
console = Console(soft_wrap=True)
# the registered domains (regen.domains), as --help lists them
DOMAIN_HELP = "The robot's domain: " + " or ".join(domains.names())
err_console = Console(stderr=True, soft_wrap=True)


def _defaults():
    from regen.runfolder import RunSettings

    return RunSettings().limits(), RunSettings()


_LIMITS, _SETTINGS = _defaults()  # the one place for defaults (regen.expand.Limits) seen by the CLI


def friendly(fn: F) -> F:
    """Show RegenError as a one-line message and exit with its code."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except RegenError as exc:
            one_line = re.sub(r"\s*\n\s*", " ", redact(str(exc), credentials=False)).strip()
            err_console.print(f"[bold red]error:[/] {shown(one_line)}")
            raise typer.Exit(exc.exit_code) from None
        except OSError as exc:  # a full disk or a read-only file system anywhere: no traceback
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EROFS):
                raise
            where = f" {os.fsdecode(exc.filename)}" if exc.filename else ""
            err_console.print(f"[bold red]error:[/] cannot write{shown(where)}: {shown(exc.strerror)}; "
                              "free some space or choose a writable place, then run the command again")
            raise typer.Exit(2) from None

    return wrapper  # type: ignore[return-value]


def _version(value: bool) -> None:
    if value:
        console.print(f"regen {package_version()}", highlight=False, markup=False)
        raise typer.Exit()


@app.callback()
def _root(verbose: bool = typer.Option(False, "--verbose", "-v", help="Log details to stderr"),
          version: bool = typer.Option(False, "--version", is_eager=True, callback=_version,
                                       help="Print the version and exit")) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    for handler in logging.getLogger().handlers:  # no log line carries a key (regen.promises.secrets)
        if not any(isinstance(f, RedactingFilter) for f in handler.filters):
            handler.addFilter(RedactingFilter())
    import warnings

    # Scenic warns on import that it cannot own sys.excepthook; we format errors ourselves
    warnings.filterwarnings("ignore", message="unable to install sys.excepthook")


@app.command("assets", **help_for("assets"))
@friendly
def assets_cmd(domain: str = typer.Argument(..., metavar="DOMAIN", help=f"A domain ({', '.join(domains.names())}) "
                                            "or a database JSON file"),
               as_json: bool = typer.Option(False, "--json", help="Print the database as JSON")) -> None:
    """Show what a simulator's asset database can simulate."""
    from regen.assets.database import database_of

    db = database_of(domain)
    if as_json:
        console.print_json(db.model_dump_json())
        return
    table = Table(title=shown(f"{db.name} assets ({db.simulator})"))
    blueprints = any(spec.blueprint for spec in db.assets.values())  # a database that exports to CARLA
    for col in ("category", "asset", "properties", "behaviors") + (("CARLA blueprint",) if blueprints else ()):
        table.add_column(col)
    for cat, members in db.categories.items():
        for a in members:
            spec = db.assets[a]
            table.add_row(shown(cat), shown(a), shown(", ".join(spec.properties)), shown(", ".join(spec.behaviors)),
                          *((shown(spec.blueprint or "-"),) if blueprints else ()))
    console.print(table)


@app.command("predicates", **help_for("predicates"))
@friendly
def predicates_cmd(domain: str = typer.Argument(None, metavar="DOMAIN", help=f"A domain ({', '.join(domains.names())}; default: all)")) -> None:
    """List the predicate library that abstract states are built from."""
    from regen.verify import list_predicates

    table = Table(title="predicate library")
    for col in ("signature", "domains", "meaning"):
        table.add_column(col)
    for spec in list_predicates(domain):
        table.add_row(escape(spec.signature()), ", ".join(spec.domains), escape(spec.doc))
    console.print(table)


def llm_options(llm: str, cache: str, replay: bool, on_call=None, timeout: float | None = None):
    """Build the LLM client the commands share, caching in ``cache`` (a command keeps its cache
    beside its output: one cache for a whole user account would mix unrelated work)."""
    from regen.llm import LLM

    return LLM(llm, cache=cache, replay=replay, on_call=on_call, timeout=timeout)


# the options expand and generate share, declared once (each command gives the default with =)
DomainOption = Annotated[str, typer.Option("--domain", "-d", metavar=DOMAIN_METAVAR, help=DOMAIN_HELP)]
LlmOption = Annotated[str, typer.Option("--llm", metavar=MODEL_METAVAR, help=LLM_HELP)]
ReplayOption = Annotated[bool, typer.Option("--replay", help=REPLAY_HELP)]
DepthOption = Annotated[int, typer.Option("--depth", min=1, max=6, help="Event layers behind the behavior")]
MaxNodesOption = Annotated[int, typer.Option("--max-nodes", min=1, help="Most cause events to accept")]
CausesOption = Annotated[int, typer.Option("--causes", min=1, max=12, help="Causes proposed per event")]
PriorOption = Annotated[str, typer.Option("--prior", help="Steer proposals, e.g. 'police car'")]
CandidateOption = Annotated[list[str], typer.Option("--candidate", help=CANDIDATE_HELP)]
CauseOption = Annotated[list[str], typer.Option("--cause", help=CAUSE_HELP)]
LlmTimeoutOption = Annotated[float, typer.Option("--llm-timeout", min=0.1, help=LLM_TIMEOUT_HELP)]


@app.command("expand", **help_for("expand"))
@friendly
def expand_cmd(
    behavior: str = typer.Argument(..., metavar="BEHAVIOR", help="The robot behavior, e.g. 'the ego-vehicle "
                                   "stops abruptly'"),
    domain: DomainOption = ...,
    out: str = typer.Option(..., "--out", "-o", metavar=FOLDER_METAVAR,
                            help="Folder for graph.json, graph.png and graph.html"),
    llm: LlmOption = "local",
    depth: DepthOption = _LIMITS.max_depth,
    max_nodes: MaxNodesOption = _LIMITS.max_nodes,
    max_calls: int = typer.Option(None, "--max-calls", min=1, help="Stop after this many model calls"),
    max_tokens: int = typer.Option(None, "--max-tokens", min=1, help="Stop after this many tokens"),
    causes: CausesOption = _LIMITS.max_causes,
    prior: PriorOption = None,
    candidate: CandidateOption = None,
    cause: CauseOption = None,
    cache: str = typer.Option(None, "--cache", metavar="<file>",
                              help="The model's answer cache (default: llm-cache.sqlite in --out)"),
    replay: ReplayOption = False,
    llm_timeout: LlmTimeoutOption = None,
) -> None:
    """Infer a causal graph of events, entities and properties behind a behavior (paper Alg. 1)."""
    from rich.live import Live
    from rich.spinner import Spinner

    from regen.core.behavior import make_behavior
    from regen.expand import Limits
    from regen.expand.run import run_expand
    from regen.promises.folders import out_folder, output_folder

    out_dir = out_folder(out)
    b = make_behavior(behavior, domain)
    output_folder(out_dir, give="a folder for graph.json, graph.png and graph.html")
    status = {"stage": "events", "text": ""}
    spinner = Spinner("dots", text="starting")
    client = None

    def on_call(ev) -> None:
        if client is not None:
            spinner.update(text=f"{status['stage']}: {client.stats.summary()}")

    # the cache lives beside the graph it made (a rerun replays it), unless --cache says otherwise
    client = llm_options(llm, cache or str(out_dir / "llm-cache.sqlite"), replay, on_call,
                         timeout=llm_timeout)
    limits = Limits(max_depth=depth, max_nodes=max_nodes, max_calls=max_calls, max_tokens=max_tokens,
                    max_causes=causes)

    def on_update(graph, what: str) -> None:
        status["stage"] = {"events": "entities", "entities": "properties"}.get(what, what)

    with Live(spinner, console=err_console, transient=True, refresh_per_second=4):
        res = run_expand(b, client, out_dir, limits=limits, prior=prior, candidates=candidate or [],
                         forced_causes=cause or [], on_update=on_update)
    g = res.graph
    paths = g.paths()
    counts = g.counts()
    console.print(f"graph: {counts.get('event:accepted', 1) - 1} causes accepted, "
                  f"{counts.get('event:rejected', 0)} rejected, "
                  f"{counts.get('event:unsimulatable', 0)} not simulatable; "
                  f"{counts.get('entity:accepted', 0)} entities, {counts.get('property:accepted', 0)} property values")
    console.print(f"stopped: {shown(g.stop_reason)}")
    console.print(f"{len(paths)} simulatable cause chain(s):")
    for p in paths:
        console.print("  - " + " -> ".join(shown(e) for e in p.events))
    if not paths:
        err_console.print("[yellow]no simulatable cause chain: try --depth, --prior, --candidate or a "
                          "stronger model (--llm openai:<model>)[/]")
    console.print(f"model use: {client.stats.summary()}")
    for name, path in res.files.items():
        console.print(f"{shown(name)}: {shown(path)}")


runs_app = typer.Typer(no_args_is_help=True, help="List and show run folders.", **group_help("runs"))
app.add_typer(runs_app, name="runs")


@contextlib.contextmanager
def _resumable(out: str) -> Iterator[None]:
    """Ctrl-C during a run: say that finished scenarios are kept and how to resume; exit 130."""
    try:
        yield
    except KeyboardInterrupt:
        err_console.print(f"[yellow]interrupted: finished scenarios are saved in {shown(out)}; "
                          "run the same command again to resume[/]")
        raise typer.Exit(130) from None


@app.command("generate", **help_for("generate"))
@friendly
def generate_cmd(
    behavior: str = typer.Argument(None, metavar="BEHAVIOR", help="The robot behavior, e.g. 'the ego-vehicle "
                                   "stops abruptly' (with --ego-trajectory: default, the behavior detected in it)"),
    domain: DomainOption = ...,
    out: str = typer.Option(..., "--out", "-o", metavar=FOLDER_METAVAR, help=RUN_OUT_HELP),
    llm: LlmOption = "local",
    replay: ReplayOption = False,
    depth: DepthOption = _LIMITS.max_depth,
    max_nodes: MaxNodesOption = _LIMITS.max_nodes,
    scenarios: int = typer.Option(_SETTINGS.max_scenarios, "--scenarios", "-n", min=1, help="Most scenarios to simulate"),
    causes: CausesOption = _LIMITS.max_causes,
    prior: PriorOption = None,
    candidate: CandidateOption = None,
    cause: CauseOption = None,
    template: str = typer.Option(None, "--ego", help="Driving: ego behavior template (default: from the text)"),
    reward: str = typer.Option(None, "--reward", help="Manipulation: reward function id (default: from the text)"),
    seed: int = typer.Option(0, "--seed", help="Random seed of solving and simulation"),
    workers: int = typer.Option(1, "--workers", min=1, max=64, help="Processes for simulation"),
    pictures: bool = typer.Option(True, "--pictures/--no-pictures", help=PICTURES_HELP),
    log: str = typer.Option("rich", "--log", help="Progress on stderr: rich (a live panel in a terminal, plain "
                            "lines in a log or pipe), quiet, or jsonl (the events on stdout)"),
    llm_timeout: LlmTimeoutOption = None,
    fresh: bool = typer.Option(False, "--fresh", help=f"{FRESH_HELP} (its model cache is kept)"),
    trajectory: str = typer.Option(None, "--ego-trajectory", metavar="<file>", help=TRAJECTORY_HELP),
    map_name: str = typer.Option(None, "--map", help="With --ego-trajectory: the file is in this generated "
                                 "map's coordinates (straight, four_way, t_junction)"),
    no_ego_story: bool = typer.Option(False, "--no-ego-story", help="Driving: leave the ego's story out of "
                                      "each scenario.xosc (the ego is placed, not driven: for a ScenarioRunner "
                                      "user whose own agent drives it)"),
) -> None:
    """The main job: behavior -> causal graph -> scenarios -> simulation -> verdicts -> report."""
    from regen.errors import ConfigError
    from regen.pipeline import generate
    from regen.pipeline.request import behavior_to_generate, export_options
    from regen.progress import make_progress
    from regen.promises.folders import out_folder
    from regen.runfolder import RunSettings

    out_dir = out_folder(out)
    if log not in ("rich", "quiet", "jsonl"):
        raise ConfigError(f"--log must be rich, quiet or jsonl, not {log!r}")
    b, lines = behavior_to_generate(behavior, domain, template=template, reward=reward, trajectory=trajectory,
                                    map_name=map_name)
    for line in lines:
        err_console.print(shown(line))
    settings = RunSettings(llm=llm, depth=depth, max_nodes=max_nodes, max_scenarios=scenarios,
                           causes=causes, prior=prior, candidates=candidate or [],
                           forced_causes=cause or [], seed=seed,
                           workers=workers, pictures=pictures, llm_timeout=llm_timeout,
                           export_options=export_options(b.domain, no_ego_story))
    with make_progress(log, console=err_console, out=console) as progress, _resumable(out):
        result = generate(b, out_dir, settings=settings, replay=replay, fresh=fresh, on_event=progress.on_event)
    if log != "jsonl":
        _print_generated(result, out_dir)


@app.command("batch", **help_for("batch"))
@friendly
def batch_cmd(
    spec: str = typer.Argument(..., metavar="SPEC.yaml", help="The batch spec: a YAML mapping with 'behaviors:', "
                               "a list of entries with text, domain, scenarios and any 'regen generate' "
                               "setting (docs/batch.md)"),
    out: str = typer.Option(..., "--out", "-o", metavar=FOLDER_METAVAR, help="The batch folder: one run folder "
                            "per behavior, batch.json, summary.json and report.html"),
    ray: str = typer.Option(None, "--ray", metavar="auto|ADDRESS", help="Run the scenarios as Ray tasks on this "
                            "cluster (HOST:PORT, or auto: the cluster of this machine, else a local one); "
                            "needs the scale extra"),
    workers: int = typer.Option(None, "--workers", min=1, max=256, help="Simulation processes (default: the "
                                "machine's cores); with --ray 'auto' and no cluster, the local cluster's CPUs"),
    replay: ReplayOption = False,
    fresh: bool = typer.Option(False, "--fresh", help="Start the batch over: each run's results are removed "
                               "(their model caches are kept)"),
    fill_coverage: bool = typer.Option(False, "--fill-coverage", help="After the behaviors ran, run one more "
                                       "scenario per cause that presents a typology class (NHTSA pre-crash, "
                                       "driving) a behavior does not cover yet and that fits it "
                                       "(docs/coverage.md); the summary says what the fill added"),
    log: str = typer.Option("rich", "--log", help="Progress on stderr: rich (a live table in a terminal, plain "
                            "lines in a log or pipe), quiet, or jsonl (the events on stdout)"),
) -> None:
    """Many behaviors from one spec: each into the usual run folder, scenarios simulated on a
    process pool or a Ray cluster, one summary report over all of them."""
    from regen.batch import run_batch
    from regen.batch.progress import make_batch_progress
    from regen.batch.terminal import print_batch
    from regen.errors import ConfigError
    from regen.promises.folders import out_folder

    out_dir = out_folder(out)
    if log not in ("rich", "quiet", "jsonl"):
        raise ConfigError(f"--log must be rich, quiet or jsonl, not {log!r}")
    with make_batch_progress(log, console=err_console, out=console) as progress, _resumable(out):
        record = run_batch(spec, out_dir, ray=ray, workers=workers, replay=replay, fresh=fresh,
                           fill_coverage=fill_coverage, on_event=progress.on_event)
    if log != "jsonl":
        print_batch(console, record, out_dir)
    if record.status == "failed":
        raise typer.Exit(1)


def _print_generated(result, out_dir) -> None:
    """A finished run in the terminal: how many scenarios are feasible and why not, then each one."""
    from regen.pipeline import summarize
    from regen.pipeline.terminal import print_outcomes

    summary = summarize(result.manifest, result.outcomes)
    relaxed = sum(o.verdict.status == "verified_after_relaxation" for o in result.outcomes)
    by = summary["verified_fsm_source"]
    notes = [f"FSM by the model: {by.get('model', 0)}, by the rules: {by.get('rules', 0)}"
             + (f", by the model with rule stages: {by['model+rules']}" if by.get("model+rules") else "")]
    notes += [f"{relaxed} after relaxing their FSM"] if relaxed else []
    notes += [f"{summary['cause_not_shown']} did not show their cause"] if summary["cause_not_shown"] else []
    notes += ([f"{summary['unfaithful']} played out but showed another cause than their title (unfaithful)"]
              if summary["unfaithful"] else [])
    console.print(f"[bold]{result.feasible}/{len(result.outcomes)} scenarios feasible[/]"
                  + (f" ({'; '.join(notes)})" if notes else "")
                  + f" ({shown(result.manifest.status)}); model: "
                  f"{result.manifest.usage_last.get('total', {}).get('calls', 0)} calls")
    print_outcomes(console, result.outcomes, out_dir)


def _mount_commands() -> None:
    """The commands that other packages define, in the order --help lists them."""
    from regen.augment.cli import augment_command
    from regen.dataset.cli import dataset_command
    from regen.dataset.probe_cli import probe_command
    from regen.evaluation.cli import eval_command
    from regen.evaluation.runs_cli import runs_list, runs_show
    from regen.falsify.cli import falsify_command
    from regen.harness.cli import test_command
    from regen.llm.cli import model_prepare, model_status, model_verify
    from regen.pipeline.import_cli import import_command
    from regen.whatif.cli import whatif_command

    app.command("whatif", help="Counterfactual what-if: edit a scenario's cause chain (--set, --remove, "
                               "--add, --ask), then ground, simulate and verify it again.",
                **help_for("whatif"))(friendly(whatif_command))
    app.command("augment", help="Augment a scene: the model proposes causes to add and entities that do not "
                                "matter; each is grounded, simulated and verified.",
                **help_for("augment"))(friendly(augment_command))
    app.command("eval", help="Diversity (embedding, Self-BLEU), feasibility, controllability, "
                             "edge-construction accuracy over run folders or text sets; typology "
                             "coverage (--coverage).",
                **help_for("eval"))(eval_command)
    app.command("test", help="Run a policy through a run's verified scenarios: pass/fail, "
                             "collisions, tests.json and junit.xml.", **help_for("test"))(test_command)
    app.command("falsify", help="Search a run's causes (set, remove, add) for what makes a policy fail where "
                                "the scripted robot copes; minimal findings with replay commands.",
                **help_for("falsify"))(falsify_command)
    app.command("import", help="Import a scenario file (OpenSCENARIO .xosc for driving): its storyboard "
                               "becomes a scenario with an FSM, simulated and verified.",
                **help_for("import"))(friendly(import_command))
    app.command("dataset", **help_for("dataset"))(friendly(dataset_command))
    app.command("probe", **help_for("probe"))(friendly(probe_command))
    runs_app.command("list", **help_for("runs list"))(friendly(runs_list))
    runs_app.command("show", **help_for("runs show"))(friendly(runs_show))
    model_app.command("status", **help_for("model status"))(friendly(model_status))
    model_app.command("prepare", **help_for("model prepare"))(friendly(model_prepare))
    model_app.command("verify", **help_for("model verify"))(friendly(model_verify))


_mount_commands()


def print_json(value: Any) -> None:
    console.print_json(json.dumps(value, default=str))


def main() -> None:
    app()


if __name__ == "__main__":
    main()
