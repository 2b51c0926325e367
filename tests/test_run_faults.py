"""A run survives faults: interrupts and kills at each stage, concurrent runs, bad options and
--out folders, corrupt files in the run folder. Signals and kills go to a real `regen generate`
subprocess (tests/support/scripted_cli.py plugs a scripted model in as `--llm scripted`)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fake_backend import FakeBackend
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.cli import app
from regen.llm import registry
from regen.llm.testing import FunctionProvider
from regen.runfolder import RunFolder

SUPPORT = Path(__file__).resolve().parent / "support"
STOP = "the ego-vehicle stops abruptly while driving forward"


def _start(run: Path, *extra: str, env: dict[str, str] | None = None) -> subprocess.Popen:
    cmd = [sys.executable, str(SUPPORT / "scripted_cli.py"), "generate", STOP, "--domain", "driving",
           "--out", str(run), "--llm", "scripted", "-n", "2", "--log", "jsonl", "--no-pictures", *extra]
    # a Ctrl-C reaches it as it reaches a terminal's foreground job (even where the test runner
    # itself was started with SIGINT ignored)
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, **(env or {})},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _wait_for(run: Path, event: str, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise AssertionError(f"the run ended before {event!r}: {proc.communicate()}")
        path = run / "events.jsonl"
        if path.exists() and (f'"event": "{event}"' in path.read_text() or event in path.read_text()):
            return
        time.sleep(0.1)
    proc.kill()
    raise AssertionError(f"no {event!r} event within {timeout} s")


def _manifest(run: Path) -> dict:
    return json.loads((run / "run.json").read_text())


def _finish(run: Path) -> subprocess.CompletedProcess:
    proc = _start(run)
    out, err = proc.communicate(timeout=300)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


@pytest.mark.slow
@pytest.mark.parametrize("event,slow", [("graph", "judge"), ("grounding", "other"), ("simulating", None)])
def test_ctrl_c_at_each_stage_stops_cleanly_and_the_rerun_resumes(tmp_path, event, slow):
    pytest.importorskip("scenic")
    run = tmp_path / "run"
    proc = _start(run, env={"REGEN_TEST_SLOW": slow or "", "REGEN_TEST_SLOW_S": "20"})
    _wait_for(run, event, proc)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "run the same command again to resume" in err and "Traceback" not in err
    assert _manifest(run)["status"] == "interrupted"
    if event == "simulating":  # the scenario in the simulator was finished and kept, not unwound
        events = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines()]
        started = [e["name"] for e in events if e.get("event") == "simulating"]
        assert started and all((run / "scenarios" / n / "verdict.json").is_file() for n in started)
        assert "finishing the current scenario" in err
    done = _finish(run)
    assert done.returncode == 0, done.stderr
    assert _manifest(run)["status"] == "done" and (run / "report.html").exists()


@pytest.mark.slow
@pytest.mark.parametrize("event", ["graph", "grounding", "scenario_done"])
def test_kill_9_loses_nothing_and_the_rerun_finishes(tmp_path, event):
    pytest.importorskip("scenic")
    run = tmp_path / "run"
    proc = _start(run)
    _wait_for(run, event, proc)
    proc.kill()
    proc.wait(timeout=30)
    finished_before = {p.parent.name: p.read_text() for p in run.glob("scenarios/*/verdict.json")}
    done = _finish(run)
    assert done.returncode == 0, done.stderr
    assert _manifest(run)["status"] == "done"
    for name, text in finished_before.items():  # finished work is kept, not redone
        assert (run / "scenarios" / name / "verdict.json").read_text() == text
    assert len(list(run.glob("scenarios/*/verdict.json"))) == 2


@pytest.mark.slow
def test_workers_die_with_the_main_process(tmp_path):
    pytest.importorskip("scenic")
    run = tmp_path / "run"
    proc = _start(run, "--workers", "2")
    _wait_for(run, '"stage": "simulate"', proc)
    time.sleep(1.0)
    children = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
    assert children, "no simulation workers were started"
    proc.kill()
    proc.wait(timeout=30)
    time.sleep(2.0)
    alive = [c for c in children if Path(f"/proc/{c}").exists()
             and "Z" not in Path(f"/proc/{c}/stat").read_text().split()[2]]
    assert alive == []
    before = {p: p.stat().st_mtime for p in run.rglob("*") if p.is_file()}
    time.sleep(2.0)
    assert {p: p.stat().st_mtime for p in run.rglob("*") if p.is_file()} == before  # nothing writes


# --- in-process, through the CLI runner ----------------------------------------------------------


@pytest.fixture
def fake_driving(monkeypatch):
    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    model = ScriptedModel(causes={STOP: ["debris lies ahead", "a bus blocks the lane"]},
                          entities={"debris lies ahead": ["debris"], "a bus blocks the lane": ["bus"]})
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
    return model


def _cli(*args: str):
    return CliRunner().invoke(app, ["generate", STOP, "--domain", "driving", "--llm", "scripted",
                                    "--log", "quiet", *args], env={"COLUMNS": "200"})


def test_a_second_run_on_a_locked_folder_stops_at_once(tmp_path, fake_driving):
    run = tmp_path / "run"
    other = RunFolder(run)
    other._check_writable()
    other.lock()  # another process holds the folder
    try:
        res = _cli("--out", str(run))
        assert res.exit_code == 2 and f"pid {os.getpid()}" in res.output and "Traceback" not in res.output
        assert fake_driving.kinds == []  # no model call was spent
    finally:
        other.unlock()
    assert _cli("--out", str(run)).exit_code == 0


@pytest.mark.parametrize("option,value,words", [("--ego", "fly_away", "unknown ego template 'fly_away'"),
                                                ("--reward", "nope", "--reward is for manipulation")])
def test_bad_options_are_refused_before_any_model_call(tmp_path, fake_driving, option, value, words):
    res = _cli("--out", str(tmp_path / "run"), option, value)
    assert res.exit_code == 2 and words in res.output
    assert fake_driving.kinds == [] and not (tmp_path / "run").exists()


def test_bad_out_folders_are_one_line_errors(tmp_path, fake_driving):
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    for out, words in ((a_file, "is a file"), (a_file / "run", "lies under a file"),
                       (Path("/proc/regen-run"), "cannot create the run folder")):
        res = _cli("--out", str(out))
        assert res.exit_code == 2 and words in res.output and "Traceback" not in res.output, res.output


def test_corrupt_scenario_files_are_redone_and_the_rest_stay(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    first, second = _manifest(run)["scenarios"]
    kept = (run / "scenarios" / second / "verdict.json").read_text()
    status = json.loads((run / "scenarios" / first / "verdict.json").read_text())["status"]
    for name in ("scenario.json", "verdict.json"):
        (run / "scenarios" / first / name).write_text("{not json")
    FakeBackend.simulated = []
    res = _cli("--out", str(run))
    assert res.exit_code == 0, res.output
    assert len(FakeBackend.simulated) == 1  # only the broken one
    assert json.loads((run / "scenarios" / first / "verdict.json").read_text())["status"] == status
    assert (run / "scenarios" / second / "verdict.json").read_text() == kept


def test_a_corrupt_run_json_is_rebuilt_and_finished_scenarios_are_kept(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    (run / "run.json").write_text("{broken")
    FakeBackend.simulated = []
    res = _cli("--out", str(run))
    assert res.exit_code == 0, res.output
    assert FakeBackend.simulated == []  # nothing redone
    m = _manifest(run)
    assert m["status"] == "done" and "rebuilt from graph.json" in m["message"]


def test_done_is_written_last(tmp_path, fake_driving, monkeypatch):
    import regen.report

    def crash(run_dir, **kw):
        raise KeyboardInterrupt  # the process dies while writing the report

    monkeypatch.setattr(regen.report, "write_report", crash)
    run = tmp_path / "run"
    res = _cli("--out", str(run))
    assert res.exit_code == 130
    assert _manifest(run)["status"] != "done"


def test_usage_and_timings_add_up_over_invocations(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run), "-n", "1").exit_code == 0
    calls = _manifest(run)["usage"]["total"]["calls"]
    timings = json.loads(next(run.glob("scenarios/*/timings.json")).read_text())
    assert {"ground", "solve", "simulate"} <= set(timings)
    (next(run.glob("scenarios/*/verdict.json"))).unlink()
    assert _cli("--out", str(run), "-n", "1").exit_code == 0
    m = _manifest(run)
    assert m["usage"]["total"]["calls"] == calls + m["usage_last"]["total"]["calls"] > calls


@pytest.mark.parametrize("name", ["graph.json", "events.jsonl", "summary.json", "report.html",
                                  "scenarios/*/path.json", "scenarios/*/files.json",
                                  "scenarios/*/timings.json", "scenarios/*/trace.json"])
def test_each_kind_of_corrupt_file_is_survived(tmp_path, fake_driving, name):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    verdicts = {p.parent.name: json.loads(p.read_text())["status"] for p in run.glob("scenarios/*/verdict.json")}
    for p in run.glob(name):
        p.write_bytes(b"\x00\xff{[" * 10)
    res = _cli("--out", str(run))
    assert res.exit_code == 0 and "Traceback" not in res.output, res.output
    assert _manifest(run)["status"] == "done"
    assert {p.parent.name: json.loads(p.read_text())["status"]
            for p in run.glob("scenarios/*/verdict.json")} == verdicts


def test_a_corrupt_model_cache_is_a_clear_error(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    (run / "llm-cache.sqlite").write_bytes(b"not a database" * 100)
    res = _cli("--out", str(run))
    assert res.exit_code == 2 and "llm-cache.sqlite" in res.output and "Traceback" not in res.output
