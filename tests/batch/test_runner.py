"""`regen batch` end to end on the fake simulator and a scripted model (test doubles of the
simulator and the model only; the batch, the main job, the pool and the CLI are the product's):
run folders per behavior, batch.json, resume, a failing behavior that does not stop the others,
and folders it refuses."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from fake_backend import FakeBackend
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.batch import run_batch
from regen.cli import app
from regen.errors import ConfigError, RunError
from regen.llm import registry
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
SLOW = "the ego-vehicle slows down while driving forward"


@pytest.fixture
def fake_driving(monkeypatch):
    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    model = ScriptedModel(causes={STOP: ["debris lies ahead", "a bus blocks the lane"],
                                  SLOW: ["a cyclist rides ahead"]},
                          entities={"debris lies ahead": ["debris"], "a bus blocks the lane": ["bus"],
                                    "a cyclist rides ahead": ["bicycle"]})
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
    return model


def _spec(tmp_path: Path, *extra: str) -> Path:
    p = tmp_path / "spec.yaml"
    p.write_text("behaviors:\n" + "".join(
        f"  - text: {t}\n    domain: driving\n    scenarios: 2\n    llm: scripted\n    depth: 1\n    pictures: false\n"
        for t in (STOP, SLOW, *extra)))
    return p


def _verdicts(run: Path) -> dict[str, str]:
    return {p.parent.name: json.loads(p.read_text())["status"] for p in sorted(run.glob("scenarios/*/verdict.json"))}


def test_a_batch_runs_each_behavior_into_its_run_folder_and_resumes(tmp_path, fake_driving) -> None:
    out = tmp_path / "batch"
    rec = run_batch(_spec(tmp_path), out, workers=2)
    assert rec.status == "done" and [b.status for b in rec.behaviors] == ["done", "done"]
    folders = [b.folder for b in rec.behaviors]
    assert folders == ["01-the-ego-vehicle-stops-abruptly-while-dri", "02-the-ego-vehicle-slows-down-while-driving"]
    stop = _verdicts(out / folders[0])
    assert sorted(stop.values()) == ["fsm_incomplete", "verified"]  # the bus never makes the ego stop
    assert list(_verdicts(out / folders[1]).values()) == ["verified"]
    on_disk = json.loads((out / "batch.json").read_text())
    assert on_disk["status"] == "done" and on_disk["executor"] == "pool" and on_disk["workers"] == 2
    summary = json.loads((out / "summary.json").read_text())
    assert (out / "report.html").is_file() and summary
    for f in folders:  # each one a run folder that `regen generate` would resume
        assert json.loads((out / f / "run.json").read_text())["status"] == "done"
    before = {f: (out / f / "scenarios").stat().st_mtime_ns for f in folders}
    calls = len(fake_driving.kinds)
    again = run_batch(_spec(tmp_path), out, workers=2)
    assert again.status == "done" and len(fake_driving.kinds) == calls  # answers and verdicts kept
    assert {f: _verdicts(out / f) for f in folders} == {folders[0]: stop, folders[1]: _verdicts(out / folders[1])}
    assert before == {f: (out / f / "scenarios").stat().st_mtime_ns for f in folders}


def test_a_failing_behavior_is_recorded_and_the_others_run(tmp_path, fake_driving) -> None:
    out = tmp_path / "batch"
    rec = run_batch(_spec(tmp_path), out, workers=1, replay=True)  # no cached answers: both fail
    assert rec.status == "failed" and {b.status for b in rec.behaviors} == {"failed"}
    assert all("no cached answer" in b.message for b in rec.behaviors)
    res = CliRunner().invoke(app, ["batch", str(_spec(tmp_path)), "--out", str(out), "--log", "quiet"],
                             env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output  # the rerun asks the model and finishes both
    assert "batch done" in res.output and res.output.count("done ") >= 2


def test_a_folder_holding_other_files_or_another_spec_is_refused_untouched(tmp_path, fake_driving) -> None:
    out = tmp_path / "batch"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="notes.txt"):
        run_batch(_spec(tmp_path), out)
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    (out / "notes.txt").unlink()
    run_batch(_spec(tmp_path), out, workers=1)
    other = tmp_path / "other"
    other.mkdir()
    with pytest.raises(RunError, match="another spec"):
        run_batch(_spec(other, "the ego-vehicle changes lanes while driving forward"), out)


def test_a_bad_spec_is_one_line_on_the_command_line_and_nothing_is_written(tmp_path, fake_driving) -> None:
    spec = tmp_path / "bad.yaml"
    spec.write_text(f"behaviors:\n  - text: {STOP}\n    domain: drivng\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["batch", str(spec), "--out", str(out)], env={"COLUMNS": "300"})
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert "behaviors entry 1" in res.output and "unknown domain 'drivng'" in res.output
    assert not out.exists()


def _draw_where(real):
    """draw_png that also notes which process drew the picture (beside it)."""
    import os

    def draw(graph, path):
        Path(str(path) + ".pid").write_text(str(os.getpid()))
        return real(graph, path)

    return draw


def refuse_to_draw(folder: str) -> list[str]:
    raise RuntimeError("no display here")


def test_a_batch_draws_each_graph_in_a_worker_and_the_report_waits_for_it(tmp_path, fake_driving,
                                                                          monkeypatch, caplog) -> None:
    """The graph's pictures are a task (off the process that asks the model), done before the
    run's report; where that task fails, this process draws them: no picture is lost."""
    import os

    from regen.expand import run as expand_run
    from regen.pipeline import run as pipeline_run

    spec = tmp_path / "spec.yaml"
    spec.write_text(_spec(tmp_path).read_text().replace("pictures: false", "pictures: true"))
    monkeypatch.setattr(expand_run, "draw_png", _draw_where(expand_run.draw_png))
    rec = run_batch(spec, tmp_path / "batch", workers=2)
    assert rec.status == "done"
    for b in rec.behaviors:
        run = tmp_path / "batch" / b.folder
        assert (run / "graph.png").stat().st_size > 0 and (run / "graph.html").is_file()
        assert int((run / "graph.png.pid").read_text()) != os.getpid()  # a worker drew it
        assert "graph.png" in (run / "report.html").read_text()

    monkeypatch.setattr(pipeline_run, "draw_graph_files", refuse_to_draw)
    spec.write_text(spec.read_text().replace("scenarios: 2", "scenarios: 1"))
    rec = run_batch(spec, tmp_path / "again", workers=2)
    assert rec.status == "done"
    for b in rec.behaviors:
        run = tmp_path / "again" / b.folder
        assert int((run / "graph.png.pid").read_text()) == os.getpid() and (run / "graph.html").is_file()
    assert "the graph's pictures were not drawn by the worker (no display here); drawing them here" in caplog.text


def test_a_behavior_whose_answers_are_all_cached_never_waits_for_the_model(tmp_path, fake_driving,
                                                                           monkeypatch) -> None:
    """The batch gives the one local model to one behavior at a time; a behavior takes its turn
    at its first call the cache cannot answer. So a resumed batch whose answers are all cached
    finishes while the model is busy elsewhere (before, each behavior waited for its turn all
    the same: seen in a resumed batch of nine behaviors, 105 s of waiting for nothing)."""
    import threading

    from regen.batch import runner

    out = tmp_path / "batch"
    assert run_batch(_spec(tmp_path), out, workers=1).status == "done"
    busy = threading.Semaphore(0)  # the model: taken by someone else for now
    monkeypatch.setattr(runner, "model_gates", lambda planned: {"scripted": busy})
    got: dict = {}
    t = threading.Thread(target=lambda: got.update(rec=run_batch(_spec(tmp_path), out, workers=1, replay=True)))
    t.start()
    t.join(timeout=30)
    finished_while_busy = not t.is_alive()
    for _ in range(4):
        busy.release()  # (the code before waited here; let it end)
    t.join()
    assert finished_while_busy
    assert got["rec"].status == "done" and [b.status for b in got["rec"].behaviors] == ["done", "done"]


def test_a_behavior_that_needs_the_model_waits_for_its_turn(tmp_path, fake_driving, monkeypatch) -> None:
    """The other half: no model call while the model is someone else's; then the batch runs."""
    import threading
    import time

    from regen.batch import runner

    busy = threading.Semaphore(0)
    monkeypatch.setattr(runner, "model_gates", lambda planned: {"scripted": busy})
    got: dict = {}
    t = threading.Thread(target=lambda: got.update(rec=run_batch(_spec(tmp_path), tmp_path / "batch", workers=1)))
    t.start()
    time.sleep(3)
    assert t.is_alive() and fake_driving.kinds == []
    busy.release()
    t.join(timeout=120)
    assert not t.is_alive() and got["rec"].status == "done" and fake_driving.kinds
    # the wait for the turn is its own figure, not the expansion's time
    timings = [json.loads(p.read_text())["timings"] for p in sorted((tmp_path / "batch").glob("*/run.json"))]
    assert max(t.get("model_wait", 0.0) for t in timings) >= 2.5
    assert all(t["expand"] < 2.5 for t in timings), timings


def test_a_wait_for_the_model_is_in_run_json_while_it_lasts(tmp_path, fake_driving, monkeypatch) -> None:
    """A batch killed while a behavior waits for its turn keeps the wait so far (before, run.json
    got it only when the wait ended: a resumed behavior showed 691 s of wall time and 67 s in
    its stages, the rest in no figure)."""
    import threading
    import time

    from regen.batch import runner
    from regen.pipeline import run as run_module

    monkeypatch.setattr(run_module, "WAIT_SLICE", 0.2)
    busy = threading.Semaphore(0)
    monkeypatch.setattr(runner, "model_gates", lambda planned: {"scripted": busy})
    out = tmp_path / "batch"
    t = threading.Thread(target=lambda: run_batch(_spec(tmp_path), out, workers=1), daemon=True)
    t.start()
    time.sleep(2.5)
    assert t.is_alive() and fake_driving.kinds == []  # still waiting: nothing asked yet
    waits = [json.loads(p.read_text())["timings"] for p in sorted(out.glob("*/run.json"))]
    assert len(waits) == 2 and all(w.get("model_wait", 0.0) >= 1.5 for w in waits), waits
    assert all(w.get("expand", 0.0) < 0.5 for w in waits), waits  # the wait is not the expansion's
    for _ in range(2):
        busy.release()
    t.join(timeout=120)
    assert not t.is_alive()
    final = [json.loads(p.read_text())["timings"] for p in sorted(out.glob("*/run.json"))]
    assert max(w["model_wait"] for w in final) >= 2.4  # counted once, not once per slice
    assert all(w["model_wait"] < 30 for w in final)


def test_the_simulators_load_once_while_the_behaviors_expand_and_a_finished_batch_loads_none(
        tmp_path, fake_driving, monkeypatch) -> None:
    marks = tmp_path / "warmed"
    marks.mkdir()

    def warm(self) -> float:  # runs in the pool's zygote, which forks the workers: one file per process
        import os

        (marks / str(os.getpid())).touch()
        return 0.0

    monkeypatch.setattr(FakeBackend, "warm", warm)
    monkeypatch.setattr(os, "cpu_count", lambda: 2)  # the two workers take every core: still once
    out = tmp_path / "batch"
    assert run_batch(_spec(tmp_path), out, workers=2).status == "done"
    pids = {int(p.name) for p in marks.iterdir()}
    assert len(pids) == 1 and os.getpid() not in pids  # once, for both workers, not in the driver
    for p in marks.iterdir():
        p.unlink()
    assert run_batch(_spec(tmp_path), out, workers=2).status == "done"
    assert not list(marks.iterdir())  # nothing left to simulate: no worker warms
