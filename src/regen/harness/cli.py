"""``regen test RUN_DIR --policy SPEC``: a run's scenarios as behavior tests of a policy, in
any domain whose backend has a policy harness.

A thin layer over :func:`regen.harness.suite.run_tests`. Mounted by :mod:`regen.cli`
(``app.command("test")(test_command)``). Exit code: 0 when every test passed (or was skipped)
and at least one ran, 1 when any failed or none ran, 2 for a bad SPEC, folder or option.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from regen.errors import RegenError
from regen.pipeline.terminal import shown

_STYLE = {"PASS": "green", "FAIL": "red", "SKIP": "yellow", "ERROR": "red"}


def default_out(run_dir: Path, policy: str) -> Path:
    """RUN_DIR/tests/<policy as a file name>: one folder per policy spec. A built-in or module
    spec is its own name; a policy file adds a short hash of its absolute path, so two files
    with one name in different folders never share a folder."""
    from regen.runfolder import RunFolder

    spec = policy.strip()
    file_part = spec if spec.endswith(".py") else spec.rpartition(":")[0]
    if file_part.endswith(".py"):
        attr = "policy" if spec.endswith(".py") else spec.rpartition(":")[2]
        where = str(Path(file_part).expanduser().absolute())
        name = f"{Path(file_part).stem}-{attr}-{hashlib.sha1(where.encode()).hexdigest()[:6]}"
    else:
        name = spec.replace(":", "-")
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "policy"
    return Path(run_dir) / RunFolder.TESTS / safe


RunDirArgument = Annotated[Path, typer.Argument(metavar="RUN_DIR", help="A run folder made by regen generate",
                                                show_default=False)]
PolicyOption = Annotated[str | None, typer.Option(
    "--policy", "-p", metavar="<spec>",
    help="A built-in policy of the run's domain (an unknown name lists them), module:callable or "
         "path/to/file.py[:callable], called every step with the domain's observation (default: the "
         "domain's first built-in)", show_default=False)]
VariantsOption = Annotated[int | None, typer.Option(
    min=1, help="Parameter variants per scenario, sampled (seeded) from its solved feasible set; "
                "variant 0 is the scenario as grounded (default 1). With --adversarial: the "
                "candidates searched per scenario (default 16)", show_default=False)]
OutOption = Annotated[str | None, typer.Option(
    "--out", "-o", metavar="<folder>", help="Folder for tests.json and junit.xml (default: RUN_DIR/tests/<policy>)",
    show_default=False)]
OracleOption = Annotated[str, typer.Option(
    help="fsm: the FSM's expected states in order, no collision and no incident; safety: no "
         "collision and no incident only")]
StepTimeoutOption = Annotated[float | None, typer.Option(
    "--step-timeout", min=0.001, help="Wall seconds a policy may take per step (default: the domain's, 1 s)",
    show_default=False)]
AdversarialOption = Annotated[bool, typer.Option(
    "--adversarial", help="Search the feasible parameters for variants that make the policy fail while the "
                          "scripted robot verifies and collides with nothing in the same variant; report them "
                          "with their parameters")]


def test_command(
    run_dir: RunDirArgument,
    policy: PolicyOption = None,
    variants: VariantsOption = None,
    seed: Annotated[int, typer.Option(help="Random seed of the variant sampling")] = 0,
    out: OutOption = None,
    oracle: OracleOption = "fsm",
    step_timeout: StepTimeoutOption = None,
    adversarial: AdversarialOption = False,
) -> None:
    """Run a policy in place of the scripted robot in every verified scenario of a run."""
    from regen.harness.adversarial import DEFAULT_BUDGET, summary_lines
    from regen.harness.cases import case_line
    from regen.harness.pictures import keep_failures
    from regen.harness.suite import open_suite, run_tests
    from regen.promises.folders import out_folder

    console = Console(highlight=False, soft_wrap=True)
    err = Console(stderr=True, soft_wrap=True)

    def show(case) -> None:
        line = case_line(case)
        tag, rest = line.split("  ", 1)
        console.print(f"[{_STYLE[tag]}]{tag}[/]  {shown(rest)}")

    files: dict[str, Path] = {}
    dest: Path | None = None
    with command_errors(err, run_dir, lambda: dest, "the finished tests are kept; run the same command again "
                        "to resume"):
        dest = (out_folder(out) if out is not None else None)
        _, _, harness = open_suite(run_dir)
        policy = policy or next(iter(harness.builtin), "")
        dest = (dest or default_out(run_dir, policy)).absolute()
        n = variants or (DEFAULT_BUDGET if adversarial else 1)
        report = run_tests(run_dir, policy, variants=n, seed=seed, step_timeout=step_timeout,
                           oracle=oracle, adversarial=adversarial, on_case=show, harness=harness,
                           on_episode=keep_failures(dest, harness, policy=policy), out=dest,
                           on_note=lambda note: err.print(f"[yellow]note:[/yellow] {shown(note)}"))
        files = {"tests": dest / "tests.json", "junit": dest / "junit.xml"}
    s = report.summary()
    for line in summary_lines(report, harness.parameter_units):
        console.print(shown(line))
    errors = f", {s['errors']} could not run" if s["errors"] else ""
    console.print(f"{s['passed']}/{s['tests']} passed, {s['skipped']} skipped{errors}; {report.collision_line()}")
    console.print(f"wrote {escape(str(files['tests']))} and {escape(str(files['junit']))}")
    console.print(_rerender(run_dir, dest))
    if s["failed"]:
        raise typer.Exit(code=1)
    if s["passed"] == 0:  # nothing was tested: a CI job must not read that as green
        err.print("[red]error:[/red] no test ran: the run has no verified scenario to test (see its "
                  "report), or every case was skipped")
        raise typer.Exit(code=1)


@contextmanager
def command_errors(err: Console, run_dir: Path, where: Callable[[], Path | None], kept: str) -> Iterator[None]:
    """How a command that runs a policy over a run (``regen test``, ``regen falsify``) ends
    early: Ctrl-C is exit 130 saying ``kept``; a :class:`RegenError` its exit code with one
    ``error:`` line; a disk that takes no more (at ``where()``, its output folder when known, or
    the run) exit 2 with one line. Any other error is raised."""
    try:
        yield
    except KeyboardInterrupt:
        err.print(f"[yellow]interrupted:[/yellow] {kept}")
        raise typer.Exit(code=130) from None
    except RegenError as exc:
        err.print(f"[red]error:[/red] {shown(str(exc))}")
        raise typer.Exit(code=exc.exit_code) from exc
    except OSError as exc:
        from regen.core.io import cannot_write, storage_error

        target = where() or Path(run_dir)
        if not cannot_write(exc, target) and not cannot_write(exc, Path(run_dir)):
            raise
        err.print(f"[red]error:[/red] {shown(storage_error(exc, target))}")
        raise typer.Exit(code=2) from None


def _rerender(run_dir: Path, dest: Path) -> str:
    from regen.runfolder import RunFolder

    return rerender_report(run_dir, dest, RunFolder.TESTS, "the tests", "these are not in it")


def rerender_report(run_dir: Path, dest: Path, section: str, what: str, elsewhere: str) -> str:
    """Rewrite RUN_DIR/report.html so it shows what a command wrote under RUN_DIR/``section``;
    the terminal line saying where it is, and (``elsewhere``) that results written elsewhere with
    --out are not in it. A report problem is only told: the results are written."""
    from regen.report import write_report as write_run_report

    inside = Path(dest).resolve().parent == (Path(run_dir) / section).resolve()
    note = "" if inside else f" (it shows {what} under {escape(str(Path(run_dir) / section))} only; {elsewhere})"
    try:
        return f"report: {escape(str(write_run_report(run_dir)))}{note}"
    except (RegenError, OSError) as exc:
        return f"[yellow]report not updated:[/yellow] {shown(str(exc))}"


def make_app() -> typer.Typer:
    """A standalone Typer app with only ``test`` (for tests)."""
    app = typer.Typer(add_completion=False)
    app.command("test")(test_command)
    return app


__all__ = ["default_out", "make_app", "rerender_report", "test_command"]
