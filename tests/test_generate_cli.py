"""`regen generate` through the CLI runner on the real simulators, with a scripted model plugged
in as a provider (``--llm scripted``), so the command runs exactly as a user's does."""

from __future__ import annotations

import json

import pytest
from fake_expansion_model import ScriptedModel
from fsm_answers import fsm
from fsm_answers import state as _state
from typer.testing import CliRunner

from regen.cli import app
from regen.errors import ProviderUnreachableError
from regen.llm import registry
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
CHILD = "a child runs across the road"
DOOR = "the robot opens the door"
PET = "the pet is waiting outside to come in"




# the graph fixed the child's behavior, start and speed: the model is asked only what the graph
# left open (the narrative)
CHILD_ROLES = {"narrative": "A child runs across the road from the sidewalk, so the ego brakes hard."}
# over-strict: the ego must brake at the very step the child is already back on the far sidewalk
STRICT_FSM = fsm(
    _state(1, "child1", "waiting", "on_sidewalk(child1)"),
    _state(2, "child1", "crossing", "on_road(child1)", "moving(child1)"),
    _state(3, "ego", "braking", "braking(ego)"),
    _state(3, "child1", "crossed", "on_sidewalk(child1)"),
)


def _plug(monkeypatch: pytest.MonkeyPatch, model, name: str = "scripted") -> None:
    monkeypatch.setitem(registry._FACTORIES, name, lambda _model, **kw: FunctionProvider(model))


def _generate(*args: str):
    return CliRunner().invoke(app, ["generate", *args, "--log", "quiet"], env={"COLUMNS": "200"})


def _child_model(**kw) -> ScriptedModel:
    return ScriptedModel(causes={STOP: [CHILD]}, entities={CHILD: ["child"]},
                         choose={"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"],
                                 "target_speed": ["moderate"]}, **kw)


@pytest.mark.slow
def test_over_strict_fsm_is_verified_after_relaxation_in_the_main_job(tmp_path, monkeypatch):
    pytest.importorskip("scenic")
    _plug(monkeypatch, _child_model(then=[CHILD_ROLES, STRICT_FSM]))
    run = tmp_path / "run"
    res = _generate(STOP, "--domain", "driving", "--out", str(run), "--llm", "scripted", "-n", "1")
    assert res.exit_code == 0, res.output
    assert "1/1 scenarios feasible (" in res.output and "; 1 after relaxing their FSM)" in res.output
    folder = run / "scenarios" / "01-a-child-runs-across-the-road"
    verdict = json.loads((folder / "verdict.json").read_text())
    assert verdict["status"] == "verified_after_relaxation" and verdict["feasible"] is True
    assert "relaxed into 2 consecutive stages" in verdict["relaxations"][0]
    scenario = json.loads((folder / "scenario.json").read_text())["scenario"]
    assert scenario["world"]["grounder"] == "model"  # the model's own FSM, relaxed; not the rules'
    report = (run / "report.html").read_text()
    assert "verified after relaxation" in report and "FSM relaxed during verification" in report
    assert "relaxed into 2 consecutive stages" in report


@pytest.mark.slow
def test_a_run_killed_after_relaxing_resumes_from_the_grounded_fsm(tmp_path, monkeypatch):
    """Seen in a batch: a worker killed after it wrote the relaxed FSM into scenario.json, but
    before the verdict, left that FSM as the scenario; the retry verified it with no relaxation
    said. The grounded scenario is kept aside and every new attempt starts from it."""
    pytest.importorskip("scenic")
    from regen.runfolder import ScenarioFolder

    class Killed(BaseException):
        pass

    def killed(self, verdict):
        raise Killed

    _plug(monkeypatch, _child_model(then=[CHILD_ROLES, STRICT_FSM]))
    run = tmp_path / "run"
    folder = run / "scenarios" / "01-a-child-runs-across-the-road"
    with monkeypatch.context() as mp:
        mp.setattr(ScenarioFolder, "write_verdict", killed)
        with pytest.raises(Killed):
            _generate(STOP, "--domain", "driving", "--out", str(run), "--llm", "scripted", "-n", "1")
    assert not (folder / "verdict.json").exists()
    grounded = json.loads((folder / "scenario.grounded.json").read_text())["scenario"]["fsm"]
    assert json.loads((folder / "scenario.json").read_text())["scenario"]["fsm"] != grounded  # relaxed
    res = _generate(STOP, "--domain", "driving", "--out", str(run), "--llm", "scripted", "-n", "1")
    assert res.exit_code == 0, res.output
    verdict = json.loads((folder / "verdict.json").read_text())
    assert verdict["status"] == "verified_after_relaxation", verdict["reason"]
    assert "relaxed into 2 consecutive stages" in verdict["relaxations"][0]
    assert json.loads((folder / "scenario.grounded.json").read_text())["scenario"]["fsm"] == grounded


@pytest.mark.slow
def test_model_errors_in_manipulation_grounding_stop_the_run_and_it_resumes(tmp_path, monkeypatch):
    pytest.importorskip("pybullet")
    expansion = dict(causes={DOOR: [PET]}, entities={PET: ["pet"]}, values={"location": ["outside the door"]},
                     choose={"location": ["outside the door"]})

    def unreachable(messages):
        raise ProviderUnreachableError("the provider is down (test)")

    class DownWhileGrounding(ScriptedModel):
        def __call__(self, messages):
            try:
                return super().__call__(messages)
            except AssertionError:  # not an expansion prompt: grounding
                unreachable(messages)

    _plug(monkeypatch, DownWhileGrounding(**expansion))
    run = tmp_path / "run"
    args = (DOOR, "--domain", "manipulation", "--out", str(run), "--llm", "scripted", "-n", "1")
    res = _generate(*args)
    assert res.exit_code == 2 and "the provider is down" in res.output and "Traceback" not in res.output
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["status"] == "failed" and "run the same command again" in manifest["message"]
    folder = run / "scenarios" / manifest["scenarios"][0]
    assert not (folder / "verdict.json").exists()  # no permanent verdict for a provider failure

    # --replay: expansion comes from the run's cache, grounding's answer is not there
    res = _generate(*args, "--replay")
    assert res.exit_code == 2 and "cache" in res.output.lower() and "--replay" in res.output
    assert json.loads((run / "run.json").read_text())["status"] == "failed"
    assert not (folder / "verdict.json").exists()

    # the provider is back: the same command finishes the scenario
    _plug(monkeypatch, ScriptedModel(**expansion, otherwise=json.dumps({"narrative": "The pet waits."})))
    res = _generate(*args)
    assert res.exit_code == 0, res.output
    assert json.loads((run / "run.json").read_text())["status"] == "done"
    assert json.loads((folder / "verdict.json").read_text())["status"] in ("verified", "fsm_incomplete")


def test_resume_with_other_settings_is_refused_unless_fresh(tmp_path, monkeypatch):
    from fake_backend import FakeBackend

    from regen import domains

    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    model = ScriptedModel(causes={STOP: ["debris lies ahead"]}, entities={"debris lies ahead": ["debris"]})
    _plug(monkeypatch, model)
    _plug(monkeypatch, model, "other")
    run = tmp_path / "run"
    base = (STOP, "--domain", "driving", "--out", str(run), "-n", "1")
    assert _generate(*base, "--llm", "scripted").exit_code == 0
    for extra, words in ((["--llm", "scripted", "--seed", "5"], "seed: 0 then, 5 now"),
                         (["--llm", "other"], "llm: 'scripted' then, 'other' now"),
                         (["--llm", "scripted", "--ego", "slow_down"],
                          "ego_template: 'stop_abruptly' then, 'slow_down' now")):
        res = _generate(*base, *extra)
        assert res.exit_code == 2, res.output
        assert "other settings" in res.output and words in res.output and "--fresh" in res.output
    assert json.loads((run / "run.json").read_text())["settings"]["seed"] == 0  # untouched
    # the same options resume (nothing to do); --fresh starts over and keeps the model cache
    assert _generate(*base, "--llm", "scripted").exit_code == 0
    res = _generate(*base, "--llm", "scripted", "--seed", "5", "--fresh")
    assert res.exit_code == 0, res.output
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["settings"]["seed"] == 5 and manifest["usage"]["total"]["model_calls"] == 0
