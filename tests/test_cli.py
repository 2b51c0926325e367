from __future__ import annotations

import json
import re
from pathlib import Path

from typer.testing import CliRunner

from regen.cli import app

runner = CliRunner()


def test_assets_json_lists_the_database() -> None:
    res = runner.invoke(app, ["assets", "driving", "--json"])
    assert res.exit_code == 0
    assert "ambulance" in json.loads(res.stdout)["assets"]


def test_bad_database_is_a_one_line_error_without_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "db.json"
    bad.write_text("{")
    res = runner.invoke(app, ["assets", str(bad)])
    assert res.exit_code == 2
    assert "error:" in res.output and "not valid JSON" in res.output
    assert "Traceback" not in res.output


def test_predicates_lists_units_unmangled() -> None:
    res = runner.invoke(app, ["predicates"])
    assert res.exit_code == 0 and "[m/s]" in res.output


def test_the_domain_help_lists_the_registered_domains() -> None:
    """No domain is written into the help: a domain registered before the CLI loads is listed."""
    import os
    import subprocess
    import sys

    from regen import domains

    res = runner.invoke(app, ["assets", "--help"])
    assert res.exit_code == 0 and all(n in res.output for n in domains.names())
    code = ("from regen import domains; domains.register('aisle', 'toydomain:AisleBackend'); "
            "from regen.cli import app; app(['assets', '--help'])")
    support = Path(__file__).resolve().parent / "support"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "COLUMNS": "200",
                              "PYTHONPATH": f"{support}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    assert "aisle, driving, manipulation" in out.stdout, out.stdout + out.stderr


# --- the first hour of a new user: the version, the help pages, output in a CI log -----------------


def test_version_prints_the_installed_version() -> None:
    from importlib.metadata import version

    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0, res.output
    assert res.output.strip() == f"regen {version('regen-sim')}"


def _command_paths() -> list[list[str]]:
    """Every command and group of ``regen``, as the words after ``regen``."""
    import typer.main

    paths: list[list[str]] = []

    def walk(cmd, path: list[str]) -> None:
        paths.append(path)
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, [*path, name])

    walk(typer.main.get_command(app), [])
    return paths


def test_every_command_is_listed() -> None:
    names = {" ".join(p) for p in _command_paths()}
    assert {"", "generate", "test", "whatif", "augment", "eval", "import", "expand", "assets", "predicates",
            "model", "model status", "runs", "runs list", "runs show"} <= names


def test_every_help_shows_an_example_flags_as_flags_and_arguments_by_name() -> None:
    for path in _command_paths():
        res = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "250"})
        assert res.exit_code == 0, (path, res.output)
        lines = [ln.strip(" │") for ln in res.output.splitlines()]
        assert "Examples:" in lines, (path, res.output)
        prefix = " ".join(["regen", *path])
        examples = lines[lines.index("Examples:") + 1:]
        assert any(ln == prefix and path or ln.startswith(prefix + " ") for ln in examples), (path, res.output)
        assert "<bool>" not in res.output, (path, res.output)  # a flag takes no value
        assert not re.search(r"\{\w+\}", res.output), (path, res.output)  # no '{run_dir}'


def test_flags_and_positionals_read_as_what_they_are() -> None:
    res = runner.invoke(app, ["test", "--help"], env={"COLUMNS": "200"})
    assert "Usage: " in res.output and "[OPTIONS] RUN_DIR" in res.output
    for command, argument in (("whatif", "SCENARIO_DIR"), ("augment", "SCENARIO_DIR"), ("generate", "[BEHAVIOR]"),
                              ("import", "FILE"), ("assets", "DOMAIN"), ("runs show", "RUN_DIR"),
                              ("eval", "[SOURCE]...")):
        res = runner.invoke(app, [*command.split(), "--help"], env={"COLUMNS": "200"})
        assert f"[OPTIONS] {argument}" in res.output, (command, res.output)
    res = runner.invoke(app, ["whatif", "--help"], env={"COLUMNS": "200"})
    assert re.search(r"--replay\s+Use only", res.output) and re.search(r"--pictures\s+--no-pictures\s+Draw",
                                                                       res.output), res.output


def test_shared_options_are_worded_alike() -> None:
    from regen.cli_help import REPLAY_HELP

    for command in ("generate", "expand", "whatif", "augment", "eval"):
        res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "400"})
        assert re.search(r"--llm\s+<model>\s+The model", res.output), command
        assert command == "eval" or REPLAY_HELP in res.output, command
        assert re.search(r"--out\s+-o\s+<folder>", res.output), command
    for command in ("generate", "import", "whatif", "augment"):  # --no-pictures everywhere, --pictures too
        res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "400"})
        assert re.search(r"--pictures\s+--no-pictures", res.output), command


def test_generate_in_a_log_prints_plain_lines_and_whole_paths(tmp_path, monkeypatch) -> None:
    """CliRunner is no terminal, like a CI log: no live panel running into the summary, a progress
    line per stage and scenario, and the report's path on one line however narrow the log."""
    from fake_expansion_model import ScriptedModel

    from regen import domains
    from regen.llm import registry
    from regen.llm.testing import FunctionProvider

    stop = "the ego-vehicle stops abruptly while driving forward"
    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    model = ScriptedModel(causes={stop: ["debris lies ahead"]}, entities={"debris lies ahead": ["debris"]})
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda _model, **kw: FunctionProvider(model))
    run = tmp_path / ("a-long-folder-name-that-a-ci-runner-might-make-" * 3) / "run"
    res = CliRunner().invoke(app, ["generate", stop, "--domain", "driving", "--out", str(run), "-n", "1",
                                   "--llm", "scripted"], env={"COLUMNS": "40"})
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert f"report: {run / 'report.html'}" in lines, res.output
    assert not set("╭│╰─") & set(res.output), res.output
    assert "stage: expand" in lines and "scenario 1/1 done: 01-debris-lies-ahead: verified" in lines
    assert any(ln.startswith("1/1 scenarios feasible") for ln in lines), res.output  # on a line of its own
    assert not any("ETA" in ln for ln in lines)


def test_plain_progress_says_at_most_a_line_every_few_seconds() -> None:
    import io

    from rich.console import Console

    from regen.progress import PlainProgress, make_progress

    now = [0.0]
    buf = io.StringIO()
    console = Console(file=buf, width=30)
    sink = PlainProgress(console, every=5.0, clock=lambda: now[0])
    sink.on_event({"event": "stage", "stage": "expand"})
    for k in range(100):  # many model calls within 10 s: two lines, not a hundred
        now[0] = k * 0.1
        sink.on_event({"event": "llm_call", "tokens": 10})
    sink.on_event({"event": "paths", "total": 2})
    sink.on_event({"event": "scenario_done", "name": "01-" + "x" * 60, "feasible": True, "status": "verified"})
    lines = buf.getvalue().splitlines()
    assert lines[0] == "stage: expand" and sum(ln.startswith("... expand") for ln in lines) == 1, lines
    assert lines[-1] == "scenario 1/2 done: 01-" + "x" * 60 + ": verified"  # whole, though the width is 30
    with make_progress("rich", console=console, out=console) as chosen:  # not a terminal: plain lines
        assert isinstance(chosen, PlainProgress)


def test_no_ego_story_is_refused_where_the_export_has_no_ego_story(tmp_path):
    res = CliRunner().invoke(app, ["generate", "the robot opens the door", "-d", "manipulation", "--no-ego-story",
                                   "--out", str(tmp_path / "run"), "--llm", "none"], env={"COLUMNS": "200"})
    assert res.exit_code == 2 and "--no-ego-story" in res.output and "manipulation" in res.output, res.output
    assert not (tmp_path / "run").exists()


def test_the_driving_assets_table_shows_the_carla_blueprints():
    wide = CliRunner().invoke(app, ["assets", "driving"], env={"COLUMNS": "250"})
    assert wide.exit_code == 0, wide.output
    assert "CARLA blueprint" in wide.output and "vehicle.diamondback.century" in wide.output
    home = CliRunner().invoke(app, ["assets", "manipulation"], env={"COLUMNS": "250"})
    assert home.exit_code == 0 and "CARLA" not in home.output  # a database with no blueprints has no column
