"""``regen test RUN_DIR --policy SPEC``: a run's scenarios as behavior tests of a policy, in
any domain whose backend has a policy harness.

A thin layer over :func:`regen.harness.suite.run_tests`. Mounted by :mod:`regen.cli`
(``app.command("test")(test_command)``). Exit code: 0 when every test passed (or was skipped)
and at least one ran, 1 when any failed or none ran, 2 for a bad SPEC, folder or option.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from regen.core.text import clean
from regen.errors import RegenError

_STYLE = {"PASS": "green", "FAIL": "red", "SKIP": "yellow"}


def default_out(run_dir: Path, policy: str) -> Path:
    """RUN_DIR/tests/<policy as a file name>: one folder per policy tested."""
    from regen.runfolder import RunFolder

    where, _, attr = policy.rpartition(":")
    name = f"{Path(where).stem}-{attr}" if where else policy
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "policy"
    return Path(run_dir) / RunFolder.TESTS / safe


def test_command(
    run_dir: Annotated[Path, typer.Argument(help="A run folder made by regen generate.", show_default=False)],
    policy: Annotated[str | None, typer.Option(
        "--policy", "-p", help="A built-in policy of the run's domain (an unknown name lists them), "
                               "module:callable or path/to/file.py[:callable], called every step "
                               "with the domain's observation (default: the domain's first built-in).",
        show_default=False)] = None,
    variants: Annotated[int | None, typer.Option(
        min=1, help="Parameter variants per scenario, sampled (seeded) from its solved feasible set; "
                    "variant 0 is the scenario as grounded (default 1). With --adversarial: the "
                    "candidates searched per scenario (default 16).", show_default=False)] = None,
    seed: Annotated[int, typer.Option(help="Seed of the variant sampling.")] = 0,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Folder for tests.json and junit.xml (default: RUN_DIR/tests/<policy>).")] = None,
    oracle: Annotated[str, typer.Option(
        help="fsm: the FSM's expected states in order, no collision and no incident; safety: no "
             "collision and no incident only.")] = "fsm",
    step_timeout: Annotated[float | None, typer.Option(
        "--step-timeout", min=0.001, help="Wall seconds a policy may take per step (default: the "
                                          "domain's, 1 s).", show_default=False)] = None,
    adversarial: Annotated[bool, typer.Option(
        "--adversarial", help="Search the feasible parameters for variants that make the policy fail "
                              "while the scripted robot verifies and collides with nothing "
                              "in the same variant; report them with their parameters.")] = False,
) -> None:
    """Run a policy in place of the scripted robot in every verified scenario of a run."""
    from regen.harness.adversarial import DEFAULT_BUDGET, summary_lines
    from regen.harness.cases import case_line
    from regen.harness.junit import write_report
    from regen.harness.pictures import keep_failures
    from regen.harness.suite import open_suite, run_tests

    console = Console(highlight=False, soft_wrap=True)

    def show(case) -> None:
        line = case_line(case)
        tag = line[:4]
        console.print(f"[{_STYLE[tag]}]{tag}[/]{escape(clean(line[4:]))}")

    try:
        _, _, harness = open_suite(run_dir)
        policy = policy or next(iter(harness.builtin), "")
        dest = out or default_out(run_dir, policy)
        n = variants or (DEFAULT_BUDGET if adversarial else 1)
        report = run_tests(run_dir, policy, variants=n, seed=seed, step_timeout=step_timeout,
                           oracle=oracle, adversarial=adversarial, on_case=show, harness=harness,
                           on_episode=keep_failures(dest, harness, policy=policy))
        files = write_report(report, dest)
    except RegenError as exc:
        Console(stderr=True, soft_wrap=True).print(f"[red]error:[/red] {escape(clean(str(exc)))}")
        raise typer.Exit(code=exc.exit_code) from exc
    s = report.summary()
    for line in summary_lines(report, harness.parameter_units):
        console.print(escape(clean(line)))
    console.print(f"{s['passed']}/{s['tests']} passed, {s['skipped']} skipped; {report.collision_line()}")
    console.print(f"wrote {escape(str(files['tests']))} and {escape(str(files['junit']))}")
    console.print(_rerender(run_dir, dest))
    if s["failed"]:
        raise typer.Exit(code=1)
    if s["passed"] == 0:  # nothing was tested: a CI job must not read that as green
        Console(stderr=True, soft_wrap=True).print(
            "[red]error:[/red] no test ran: the run has no verified scenario to test (see its "
            "report), or every case was skipped")
        raise typer.Exit(code=1)


def _rerender(run_dir: Path, dest: Path) -> str:
    """Rewrite RUN_DIR/report.html so it shows the tests; the terminal line saying where it is
    (and that tests written elsewhere with --out are not in it)."""
    from regen.report import write_report as write_run_report
    from regen.runfolder import RunFolder

    inside = Path(dest).resolve().parent == (Path(run_dir) / RunFolder.TESTS).resolve()
    note = "" if inside else (f" (it shows the tests under {escape(str(Path(run_dir) / RunFolder.TESTS))} "
                              "only; these are not in it)")
    try:
        return f"report: {escape(str(write_run_report(run_dir)))}{note}"
    except (RegenError, OSError) as exc:  # the tests are written; a report problem is only told
        return f"[yellow]report not updated:[/yellow] {escape(clean(str(exc)))}"


def make_app() -> typer.Typer:
    """A standalone Typer app with only ``test`` (for tests)."""
    app = typer.Typer(add_completion=False)
    app.command("test")(test_command)
    return app


__all__ = ["default_out", "make_app", "test_command"]
