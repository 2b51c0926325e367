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
from regen.runfolder import RunFolder, ScenarioFolder

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


# --- no command deletes what it did not write ----------------------------------------------------


def _one_line(res, *says: str) -> str:
    """Exit 2 and one 'error: ...' line holding every phrase of ``says``, no traceback."""
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in res.output, res.output
    for phrase in says:
        assert phrase in lines[0], (phrase, lines[0])
    return lines[0]


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_fresh_refuses_a_folder_that_is_not_a_run_and_deletes_nothing(tmp_path, fake_driving):
    mine = tmp_path / "mywork"
    (mine / "scenarios" / "mywork").mkdir(parents=True)
    (mine / "scenarios" / "mywork" / "data.csv").write_text("a,b\n1,2\n")
    (mine / "run.json").write_text('{"my": "own settings"}')  # another tool's file of that name
    (mine / "notes.txt").write_text("do not lose")
    before = _files(mine)
    line = _one_line(_cli("--out", str(mine), "--fresh"), "--fresh", "nothing was removed",
                     "choose another --out")
    assert "run.json" in line and "notes.txt" in line
    assert _files(mine) == before and sorted(p.name for p in mine.iterdir()) == ["notes.txt", "run.json", "scenarios"]
    assert fake_driving.kinds == []  # stopped before any model call


def test_fresh_keeps_what_a_user_added_to_a_run_folder(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    (run / "scenarios" / "mywork").mkdir()
    (run / "scenarios" / "mywork" / "data.csv").write_text("mine")
    (run / "notes.txt").write_text("mine too")
    before = _files(run)
    line = _one_line(_cli("--out", str(run), "--fresh"), "holds what a run does not write",
                     "nothing was removed")
    assert "scenarios/mywork/" in line and "notes.txt" in line
    assert _files(run) == before  # not one file of the run went either


def test_fresh_removes_the_runs_files_and_keeps_the_cache_and_test_results(tmp_path, fake_driving):
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    (run / "tests" / "my_policy").mkdir(parents=True)
    (run / "tests" / "my_policy" / "tests.json").write_text("{}")  # regen test's, not generate's
    cache = (run / "llm-cache.sqlite").read_bytes()
    FakeBackend.simulated = []
    assert _cli("--out", str(run), "--fresh").exit_code == 0
    assert len(FakeBackend.simulated) == 2  # started over
    assert (run / "tests" / "my_policy" / "tests.json").read_text() == "{}"
    assert (run / "llm-cache.sqlite").read_bytes()[:100] == cache[:100]
    assert _manifest(run)["status"] == "done"


@pytest.mark.parametrize("command", ["generate", "expand", "eval"])
def test_an_empty_out_is_an_error(tmp_path, fake_driving, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    args = {"generate": ["generate", STOP, "--domain", "driving", "--llm", "scripted", "--log", "quiet"],
            "expand": ["expand", STOP, "--domain", "driving", "--llm", "scripted"],
            "eval": ["eval", "example:regen_style_driving", "--no-embeddings", "--repeats", "1"]}[command]
    res = CliRunner().invoke(app, [*args, "--out", ""], env={"COLUMNS": "200"})
    _one_line(res, "--out is empty", "give a folder path")
    assert list(tmp_path.iterdir()) == [] and fake_driving.kinds == []


def test_an_unreadable_run_json_names_a_safe_way_forward(tmp_path, fake_driving):
    run = tmp_path / "mine"
    run.mkdir()
    (run / "run.json").write_text("{not json")
    (run / "thesis.tex").write_text("years of work")
    line = _one_line(_cli("--out", str(run)), "run.json", "move", "aside", "another --out")
    assert "--fresh" not in line
    assert (run / "thesis.tex").read_text() == "years of work" and (run / "run.json").read_text() == "{not json"
    assert sorted(p.name for p in run.iterdir()) == ["run.json", "thesis.tex"]  # no lock file left


# --- a recovered provider is asked again; expand keeps its cache beside its output ---------------


class Flaky:
    """The scripted model behind a switch: garbage while broken, then its real answers."""

    def __init__(self, model: ScriptedModel):
        self.model, self.broken, self.calls = model, True, 0

    def __call__(self, messages):
        self.calls += 1
        return "I am sorry, the server is overloaded" if self.broken else self.model(messages)


def test_a_rerun_asks_a_provider_that_has_recovered(tmp_path, fake_driving, monkeypatch):
    flaky = Flaky(fake_driving)
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(flaky))
    args = ["expand", STOP, "--domain", "driving", "--llm", "scripted", "--out", str(tmp_path / "g")]
    broken = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    assert "0 simulatable cause chain" in broken.output or broken.exit_code != 0, broken.output
    flaky.broken = False
    fixed = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    assert fixed.exit_code == 0, fixed.output
    assert "2 simulatable cause chain(s)" in fixed.output, fixed.output
    assert {"propose", "judge"} <= set(fake_driving.kinds)  # the provider was asked again


def test_expand_keeps_its_cache_beside_its_output(tmp_path, fake_driving):
    import os as _os

    out = tmp_path / "g"
    res = CliRunner().invoke(app, ["expand", STOP, "--domain", "driving", "--llm", "scripted",
                                   "--out", str(out)], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert (out / "llm-cache.sqlite").is_file()
    shared = Path(_os.environ["REGEN_CACHE_DIR"])
    assert not list(shared.rglob("llm-cache.sqlite*"))  # nothing in the account-wide cache
    other = tmp_path / "elsewhere.sqlite"
    assert CliRunner().invoke(app, ["expand", STOP, "--domain", "driving", "--llm", "scripted", "--out",
                                    str(tmp_path / "h"), "--cache", str(other)]).exit_code == 0
    assert other.is_file() and not (tmp_path / "h" / "llm-cache.sqlite").exists()


# --- a full disk or a read-only folder during a run ---------------------------------------------


@pytest.fixture
def disk(monkeypatch):
    """A run folder's disk that fills up on demand: ``disk.full(where)`` makes every atomic write
    of a path containing ``where`` fail as a full disk (or ``disk.error``) until ``disk.free()``."""
    import errno as _errno

    import regen.core.io as io

    real = io.atomic_write_bytes

    class Disk:
        where: str | None = None
        error = _errno.ENOSPC
        refused: list[str] = []

        def full(self, where: str = "", error: int = _errno.ENOSPC) -> None:
            self.where, self.error = where, error

        def free(self) -> None:
            self.where = None

    d = Disk()

    def write(path, data):
        if d.where is not None and d.where in str(path):
            d.refused.append(str(path))
            raise OSError(d.error, os.strerror(d.error), str(path))
        return real(path, data)

    monkeypatch.setattr(io, "atomic_write_bytes", write)
    return d


def _drawing(monkeypatch, disk=None):
    """FakeBackend draws a small picture per scenario (through the run folder's disk)."""
    import regen.core.io as io

    def render(self, scenario, trace, verdict, out_dir):
        gif = Path(out_dir) / "bird_eye.gif"
        io.atomic_write_bytes(gif, b"GIF89a" + scenario.narrative.encode())
        return {"animation": gif}

    monkeypatch.setattr(FakeBackend, "render", render)


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_full_disk_stops_the_run_with_one_line_and_the_resume_finishes(tmp_path, fake_driving, disk,
                                                                         workers):
    run = tmp_path / "run"
    disk.full("trace.json" if workers == "2" else "scenarios")  # in the simulation workers
    line = _one_line(_cli("--out", str(run), "--workers", workers), "cannot write",
                     "No space left on device", "free some disk space", "run the same command again")
    assert disk.refused or "trace.json" in line  # a worker's refusals are in the worker
    m = _manifest(run)
    assert m["status"] == "failed" and "No space left on device" in m["message"]
    disk.free()
    res = _cli("--out", str(run))
    assert res.exit_code == 0, res.output
    assert _manifest(run)["status"] == "done" and len(list(run.glob("scenarios/*/verdict.json"))) == 2
    assert "scenarios" in line


def test_a_disk_that_takes_nothing_more_still_says_failed_in_run_json(tmp_path, fake_driving, disk):
    run = tmp_path / "run"
    disk.full("scenarios")
    FakeBackend.interrupt_on = None
    real_write = RunFolder.write_manifest

    def manifest_too(self, manifest):  # once the disk is full, run.json cannot be replaced either
        if manifest.status != "running":
            raise OSError(28, "No space left on device", str(self / self.MANIFEST))
        return real_write(self, manifest)

    import unittest.mock as mock

    with mock.patch.object(RunFolder, "write_manifest", manifest_too):
        _one_line(_cli("--out", str(run)), "No space left on device")
    assert _manifest(run)["status"] == "failed"  # written in place over the old run.json


@pytest.mark.parametrize("error,says", [(30, "make"), (13, "make")])  # EROFS, EACCES
def test_a_read_only_run_folder_stops_the_run_with_one_line(tmp_path, fake_driving, disk, error, says):
    run = tmp_path / "run"
    disk.full("scenarios", error=error)
    line = _one_line(_cli("--out", str(run)), "cannot write", f"{says} {run} writable")
    assert _manifest(run)["status"] == "failed", line
    disk.free()
    assert _cli("--out", str(run)).exit_code == 0


def test_a_full_disk_while_drawing_is_redrawn_on_resume(tmp_path, fake_driving, disk, monkeypatch):
    _drawing(monkeypatch)
    run = tmp_path / "run"
    disk.full("bird_eye.gif")
    _one_line(_cli("--out", str(run)), "bird_eye.gif", "No space left on device")
    assert _manifest(run)["status"] == "failed"
    disk.free()
    assert _cli("--out", str(run)).exit_code == 0
    for name in _manifest(run)["scenarios"]:
        folder = run / "scenarios" / name
        assert (folder / "bird_eye.gif").is_file(), name
        assert json.loads((folder / "files.json").read_text())["animation"] == "bird_eye.gif"


def test_pictures_missing_from_a_finished_scenario_are_redrawn_on_resume(tmp_path, fake_driving, monkeypatch):
    _drawing(monkeypatch)
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    first = run / "scenarios" / _manifest(run)["scenarios"][0]
    verdict = (first / "verdict.json").read_text()
    (first / "bird_eye.gif").unlink()  # e.g. cleaned away while the disk was full
    FakeBackend.simulated = []
    assert _cli("--out", str(run)).exit_code == 0
    assert (first / "bird_eye.gif").is_file()
    assert FakeBackend.simulated == [] and (first / "verdict.json").read_text() == verdict  # only drawn


class _Killed(BaseException):
    """The process dying in the middle of a step (nothing catches it, as nothing survives a kill)."""


def test_a_kill_while_drawing_keeps_the_verdict_and_the_resume_draws_the_pictures(tmp_path, fake_driving,
                                                                                   monkeypatch):
    _drawing(monkeypatch)
    drawn = FakeBackend.render

    def killed(self, scenario, trace, verdict, out_dir):
        raise _Killed

    monkeypatch.setattr(FakeBackend, "render", killed)
    run = tmp_path / "run"
    with pytest.raises(_Killed):
        CliRunner().invoke(app, ["generate", STOP, "--domain", "driving", "--llm", "scripted", "--log", "quiet",
                                 "--out", str(run)], catch_exceptions=False)
    first = run / "scenarios" / _manifest(run)["scenarios"][0]
    assert (first / "verdict.json").is_file() and not (first / "bird_eye.gif").exists()
    verdict = (first / "verdict.json").read_text()
    monkeypatch.setattr(FakeBackend, "render", drawn)
    FakeBackend.simulated = []
    res = _cli("--out", str(run))
    assert res.exit_code == 0, res.output
    assert (first / "bird_eye.gif").is_file()
    assert json.loads((first / "files.json").read_text())["animation"] == "bird_eye.gif"
    assert (first / "verdict.json").read_text() == verdict  # kept, and drawn without simulating again
    assert ScenarioFolder(first).scenario().narrative not in FakeBackend.simulated
    assert len(list(run.glob("scenarios/*/bird_eye.gif"))) == 2


def test_a_run_without_pictures_gets_them_when_resumed_with_pictures(tmp_path, fake_driving, monkeypatch):
    _drawing(monkeypatch)
    run = tmp_path / "run"
    assert _cli("--out", str(run), "--no-pictures").exit_code == 0
    assert not list(run.glob("scenarios/*/bird_eye.gif"))
    assert _cli("--out", str(run)).exit_code == 0
    assert len(list(run.glob("scenarios/*/bird_eye.gif"))) == 2


def test_a_drawing_that_fails_for_good_is_not_retried_on_every_rerun(tmp_path, fake_driving, monkeypatch):
    calls = []

    def render(self, scenario, trace, verdict, out_dir):
        calls.append(scenario.narrative)
        raise ValueError("a bug in the drawing code")

    monkeypatch.setattr(FakeBackend, "render", render)
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    assert len(calls) == 2 and all("render failed" in p.read_text() for p in run.glob("scenarios/*/error.txt"))
    assert _cli("--out", str(run)).exit_code == 0
    assert len(calls) == 2  # kept in error.txt, not redone at every rerun


def test_a_drawing_an_older_version_lost_to_a_full_disk_is_redrawn(tmp_path, fake_driving, monkeypatch):
    _drawing(monkeypatch)
    run = tmp_path / "run"
    assert _cli("--out", str(run)).exit_code == 0
    first = run / "scenarios" / _manifest(run)["scenarios"][0]
    (first / "bird_eye.gif").unlink()  # as an older version left it: verdict, error.txt, no picture
    (first / "files.json").write_text("{}")
    (first / "error.txt").write_text("render failed:\nOSError: [Errno 28] No space left on device\n")
    assert _cli("--out", str(run)).exit_code == 0
    assert (first / "bird_eye.gif").is_file() and not (first / "error.txt").exists()


def test_a_full_disk_during_expand_is_one_line(tmp_path, fake_driving, disk):
    disk.full("graph.json")
    res = CliRunner().invoke(app, ["expand", STOP, "--domain", "driving", "--llm", "scripted",
                                   "--out", str(tmp_path / "g")], env={"COLUMNS": "200"})
    _one_line(res, "cannot write", "graph.json", "No space left on device")
