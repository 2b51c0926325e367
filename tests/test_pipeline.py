from __future__ import annotations

import json
from pathlib import Path

import pytest
from fake_backend import FakeBackend
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.core.behavior import Behavior
from regen.core.verdict import Verdict
from regen.errors import RunError
from regen.llm import LLM
from regen.llm.testing import FunctionProvider
from regen.pipeline import RunSettings, generate

STOP = "the ego-vehicle stops abruptly"


@pytest.fixture(autouse=True)
def fake_driving(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    FakeBackend.interrupt_on = None


def _model() -> ScriptedModel:
    return ScriptedModel(
        causes={STOP: ["a jaywalker walked in front", "a bus blocks the lane", "an impossible event",
                       "debris lies ahead"]},
        entities={"a jaywalker walked in front": ["adult"], "a bus blocks the lane": ["bus"],
                  "an impossible event": ["sedan"], "debris lies ahead": ["debris"]},
        values={"start_location": ["in front of the ego-vehicle"]},
        choose={"start_location": ["in front of the ego-vehicle"], "behavior": ["stationary"]})


def _llm(model: ScriptedModel, run: Path, **kw) -> LLM:
    return LLM(FunctionProvider(model), cache=run / "llm-cache.sqlite", **kw)


def test_run_folder_has_verdicts_graph_and_manifest(tmp_path: Path) -> None:
    run = tmp_path / "run"
    res = generate(Behavior(text=STOP, domain="driving"), run, settings=RunSettings(max_scenarios=4, causes=4),
                   llm=_llm(_model(), run))
    by = {o.folder.split("-", 1)[1]: o.verdict for o in res.outcomes}
    assert by["a-jaywalker-walked-in-front"].feasible
    assert by["debris-lies-ahead"].feasible
    assert by["a-bus-blocks-the-lane"].status == "fsm_incomplete"  # simulated, but the ego never stopped
    assert by["an-impossible-event"].status == "grounding_failed" and "cannot place" in by["an-impossible-event"].reason
    for name in res.manifest.scenarios:
        v = json.loads((run / "scenarios" / name / "verdict.json").read_text())
        assert isinstance(v["feasible"], bool)
    assert (run / "scenarios" / res.manifest.scenarios[0] / "trace.json").exists()
    assert (run / "graph.json").exists() and (run / "graph.png").exists()
    summary = json.loads((run / "summary.json").read_text())
    assert summary["scenarios"] == 4 and summary["feasible"] == 2 and summary["success_rate"] == 0.5
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["status"] == "done" and manifest["usage"]["total"]["model_calls"] > 0
    events = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines()]
    assert [e["event"] for e in events if e["event"] == "scenario_done"].__len__() == 4


def test_interrupted_run_resumes_without_redoing_work(tmp_path: Path) -> None:
    run = tmp_path / "run"
    behavior = Behavior(text=STOP, domain="driving")
    FakeBackend.interrupt_on = "debris"  # the third scenario to simulate
    with pytest.raises(KeyboardInterrupt):
        generate(behavior, run, settings=RunSettings(max_scenarios=4, causes=4, pictures=False), llm=_llm(_model(), run))
    assert json.loads((run / "run.json").read_text())["status"] == "interrupted"
    done_before = list(FakeBackend.simulated)
    assert len(done_before) == 2

    model = _model()
    llm = _llm(model, run)
    res = generate(behavior, run, settings=RunSettings(max_scenarios=4, causes=4, pictures=False), llm=llm)
    assert llm.stats.total.model_calls == 0 and model.kinds == []  # every answer from the run's cache
    assert FakeBackend.simulated[len(done_before):] == ["A debris makes the ego stop."]  # only what was left
    assert sum(o.skipped for o in res.outcomes) == 3  # two simulated + the grounding failure
    assert res.manifest.status == "done" and len(res.outcomes) == 4


def test_replay_with_an_empty_cache_fails_cleanly(tmp_path: Path) -> None:
    from regen.errors import CacheMissError

    run = tmp_path / "run"
    with pytest.raises(CacheMissError):
        generate(Behavior(text=STOP, domain="driving"), run, llm=_llm(_model(), run, replay=True))
    assert json.loads((run / "run.json").read_text())["status"] == "failed"


def test_a_folder_of_another_behavior_is_refused(tmp_path: Path) -> None:
    run = tmp_path / "run"
    generate(Behavior(text=STOP, domain="driving"), run, settings=RunSettings(max_scenarios=1, pictures=False),
             llm=_llm(_model(), run))
    with pytest.raises(RunError, match="another behavior"):
        generate(Behavior(text="the ego-vehicle changes lanes", domain="driving"), run,
                 llm=_llm(_model(), run))


def test_a_corrupt_verdict_is_redone(tmp_path: Path) -> None:
    run = tmp_path / "run"
    b = Behavior(text=STOP, domain="driving")
    res = generate(b, run, settings=RunSettings(max_scenarios=1, pictures=False), llm=_llm(_model(), run))
    vpath = run / "scenarios" / res.manifest.scenarios[0] / "verdict.json"
    vpath.write_text("{broken")
    res2 = generate(b, run, settings=RunSettings(max_scenarios=1, pictures=False), llm=_llm(_model(), run))
    assert not res2.outcomes[0].skipped
    Verdict.model_validate_json(vpath.read_text())


def test_cli_generate_jsonl_and_runs_commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from regen.cli import app
    from regen.llm import registry

    model = _model()  # a provider plugin, so the CLI runs exactly as a user's command does
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
    run = tmp_path / "run"
    runner = CliRunner()
    res = runner.invoke(app, ["generate", STOP, "--domain", "driving", "--out", str(run), "--log", "jsonl",
                              "-n", "2", "--llm", "scripted"])
    assert res.exit_code == 0, res.output
    events = [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]
    assert events[-1]["event"] == "finished" and events[-1]["scenarios"] == 2
    listed = runner.invoke(app, ["runs", "list", str(tmp_path)], env={"COLUMNS": "250"})
    assert listed.exit_code == 0 and "stops abruptly" in listed.output
    shown = runner.invoke(app, ["runs", "show", str(run)], env={"COLUMNS": "250"})
    assert shown.exit_code == 0 and "verified" in shown.output


def test_cli_rejects_bad_input_without_traceback(tmp_path: Path) -> None:
    from regen.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["generate", "   ", "--domain", "driving", "--out", str(tmp_path / "r")])
    assert res.exit_code == 2 and "describe the robot behavior" in res.output and "Traceback" not in res.output
    res = runner.invoke(app, ["generate", "x", "--domain", "flying", "--out", str(tmp_path / "r")])
    assert res.exit_code == 2 and "unknown domain 'flying'" in res.output


def test_select_paths_prefers_distinct_causes_then_property_variants() -> None:
    from regen.core.graph import CausePath, PathEntity
    from regen.pipeline import select_paths

    b = Behavior(text=STOP, domain="driving")
    a = CausePath(behavior=b, events=["a jaywalker", STOP], entities=[
        PathEntity(asset="adult", event="a jaywalker", properties={"start_location": ["roadside_ahead", "crosswalk_ahead"]})])
    c = CausePath(behavior=b, events=["debris", STOP], entities=[PathEntity(asset="debris", event="debris")])
    chosen = select_paths([a, c], 3)
    assert [p.events[0] for p in chosen] == ["a jaywalker", "debris", "a jaywalker"]
    assert [p.entities[0].properties.get("start_location") for p in chosen] == [
        ["roadside_ahead"], None, ["crosswalk_ahead"]]


def test_a_graph_choice_grounding_cannot_honor_is_an_ungroundable_verdict(tmp_path: Path) -> None:
    from regen.core.graph import CausePath, PathEntity
    from regen.errors import UngroundableError
    from regen.pipeline import ground_stage
    from regen.runfolder import ScenarioFolder

    class Refuses(FakeBackend):
        def ground(self, path, llm, *, seed=0):
            raise UngroundableError("bicycle1: the graph chose behavior 'stationary' at 'crosswalk_ahead', "
                                    "which no primitive of a bicycle can start from")

    path = CausePath(behavior=Behavior(text=STOP, domain="driving"), events=["a cyclist crosses", STOP],
                     entities=[PathEntity(asset="bicycle", event="a cyclist crosses")])
    folder = ScenarioFolder(tmp_path / "s")
    verdict = ground_stage(Refuses(), path, None, folder)
    assert verdict.status == "ungroundable" and not verdict.feasible
    assert "bicycle1" in verdict.reason and folder.verdict() == verdict


def test_a_resumed_folder_holds_its_path_when_the_behavior_carries_tuples(tmp_path: Path) -> None:
    """A recorded ego's poses are tuples in a fresh path and lists once read back: the same path,
    so a rerun reuses the folder instead of grounding again."""
    from regen.core.graph import CausePath, PathEntity
    from regen.runfolder import ScenarioFolder

    poses = ((0.0, 0.0, 0.0, 10.0), (0.1, 1.0, 0.0, 9.5))
    behavior = Behavior(text=STOP, domain="driving", params={"recorded": {"poses": poses, "dt": 0.1}})
    path = CausePath(behavior=behavior, events=["a cyclist crosses", STOP],
                     entities=[PathEntity(asset="bicycle", event="a cyclist crosses")])
    folder = ScenarioFolder(tmp_path / "s")
    folder.start(path)
    assert folder.holds(path)
    other = path.model_copy(update={"events": ["a child crosses", STOP]})
    assert not folder.holds(other)


def test_a_run_killed_after_grounding_keeps_its_stage_times_and_model_usage(tmp_path: Path,
                                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """kill -9 during the simulation (emulated: the simulation never returns and nothing runs
    at the end): run.json already holds the expansion and grounding times and the model calls
    made; the resume adds to them, counting no call twice (seen: a batch killed mid-run showed
    a grounding of 47 s as 0.00 s)."""
    from regen.pipeline.run import MainJob

    class Killed(BaseException):
        pass

    def killed(self, pending):
        raise Killed

    run = tmp_path / "run"
    model = _model()
    with monkeypatch.context() as mp:
        mp.setattr(MainJob, "simulate", killed)
        mp.setattr(MainJob, "close", lambda self: None)  # a killed process writes nothing more
        with pytest.raises(Killed):
            generate(Behavior(text=STOP, domain="driving"), run, settings=RunSettings(max_scenarios=4, causes=4),
                     llm=_llm(model, run))
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["status"] == "running"
    assert manifest["timings"]["expand"] > 0 and manifest["timings"]["ground"] > 0
    calls = manifest["usage"]["total"]["model_calls"]
    assert calls == len(model.kinds) > 0
    res = generate(Behavior(text=STOP, domain="driving"), run, settings=RunSettings(max_scenarios=4, causes=4),
                   llm=_llm(model, run))
    after = json.loads((run / "run.json").read_text())
    assert res.manifest.status == "done" and after["usage"]["total"]["model_calls"] == len(model.kinds)
    assert after["timings"]["ground"] >= manifest["timings"]["ground"]


@pytest.mark.parametrize("stage", ["ground", "simulate"])
def test_a_run_killed_within_a_stage_keeps_the_time_of_the_scenarios_it_finished(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str) -> None:
    """kill -9 after the stage finished one scenario (emulated: the next one never returns and
    nothing runs at the end): run.json already holds that scenario's share of the stage's time
    (seen: a batch killed after a behavior's scenarios were simulated showed 'simulate 0.00 s')."""
    from regen.pipeline import run as run_module
    from regen.pipeline.run import MainJob

    class Killed(BaseException):
        pass

    calls = []
    name = "ground_stage" if stage == "ground" else "simulate_stage"
    original = getattr(run_module, name)

    def once(*args, **kwargs):
        calls.append(name)
        if len(calls) > 1:
            raise Killed
        return original(*args, **kwargs)

    run = tmp_path / "run"
    with monkeypatch.context() as mp:
        mp.setattr(run_module, name, once)
        mp.setattr(MainJob, "close", lambda self: None)  # a killed process writes nothing more
        with pytest.raises(Killed):
            generate(Behavior(text=STOP, domain="driving"), run, settings=RunSettings(max_scenarios=4, causes=4),
                     llm=_llm(_model(), run))
    assert len(calls) == 2
    timings = json.loads((run / "run.json").read_text())["timings"]
    assert timings.get(stage, 0.0) > 0, timings
