"""``regen augment``: a hand-built scene with one distractor (a pedestrian walking along the sidewalk); the (queued) model proposes a cause
to add and calls the distractor irrelevant; the addition is grounded, simulated and verified, the
distractor removed and the scene simulated again, and the claim holds because the behavior is
still explained. A claim about the cause itself fails."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from driving_chains import chain
from manipulation_chains import pet_door_path
from typer.testing import CliRunner

pytest.importorskip("scenic")

from regen.cli import app  # noqa: E402
from regen.llm import registry  # noqa: E402
from regen.llm.testing import QueuedProvider  # noqa: E402
from regen.pipeline.stages import run_path  # noqa: E402

pytestmark = pytest.mark.slow

SCENE = chain("stop_abruptly", "the truck in front brakes hard",
              ("truck", {"behavior": ["brake_ahead"], "start_location": ["ahead_same_lane"],
                         "target_speed": ["moderate"]}),
              ("adult", {"behavior": ["walk_along"], "start_location": ["roadside_ahead"]}))


@pytest.fixture
def scene(tmp_path) -> Path:
    folder = tmp_path / "run" / "scenarios" / "01-truck-brakes"
    out = run_path(SCENE, folder, pictures=False)
    assert out.verdict.feasible, out.verdict.reason
    return folder


def _augment(monkeypatch, folder: Path, answer: dict, *args: str):
    provider = QueuedProvider([answer])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    res = CliRunner().invoke(app, ["augment", str(folder), "--llm", "queued:test", "--no-judge", "--no-pictures",
                                   *args], env={"COLUMNS": "200"})
    return res, provider


def test_an_addition_verifies_and_the_distractor_is_found_irrelevant(scene, tmp_path, monkeypatch):
    answer = {"add": ["a cyclist rides ahead"], "irrelevant": ["adult1", "ghost9"]}
    res, provider = _augment(monkeypatch, scene, answer, "--out", str(tmp_path / "aug"))
    assert res.exit_code == 0, res.output
    prompt = provider.requests[0][-1]["content"]
    assert "truck1" in prompt and "adult1" in prompt and "stops abruptly" in prompt
    record = json.loads((tmp_path / "aug" / "01-truck-brakes-augment" / "augment.json").read_text())
    (added,) = record["additions"]
    assert added["proposal"] == "a cyclist rides ahead" and added["holds"] and added["status"].startswith("verified")
    path = json.loads((Path(added["folder"]) / "path.json").read_text())
    assert "bicycle" in [e["asset"] for e in path["entities"]]
    (cone,) = record["irrelevant"]
    assert cone["proposal"] == "adult1" and cone["holds"]
    kept = json.loads((Path(cone["folder"]) / "path.json").read_text())
    assert [e["asset"] for e in kept["entities"]] == ["truck"]
    assert record["dropped"] == ["ghost9"]  # named by the model, not in the scene
    html = (tmp_path / "aug" / "01-truck-brakes-augment" / "augment.html").read_text()
    assert "a cyclist rides ahead" in html and "adult1" in html


def test_a_claim_that_the_cause_is_irrelevant_fails_and_an_unknown_addition_is_not_applied(scene, tmp_path,
                                                                                           monkeypatch):
    answer = {"add": ["a tree grows"], "irrelevant": ["truck1"]}
    res, _ = _augment(monkeypatch, scene, answer, "--out", str(tmp_path / "aug"))
    assert res.exit_code == 0, res.output
    record = json.loads((tmp_path / "aug" / "01-truck-brakes-augment" / "augment.json").read_text())
    (tree,) = record["additions"]
    assert tree["status"] == "not_applied" and not tree["holds"] and "name no asset" in tree["reason"]
    (truck,) = record["irrelevant"]
    assert not truck["holds"]  # without the truck nothing stops the ego
    # a hand-built scene has no run.json: the counterfactuals go beside augment.json (in a run: RUN/whatif)
    assert Path(truck["folder"]).parent == tmp_path / "aug"
    assert "claim fails" in res.output


def test_an_addition_is_judged_as_a_cause_of_the_behavior_and_the_judge_never_overrides(scene, tmp_path, monkeypatch):
    provider = QueuedProvider([{"add": ["a cyclist rides ahead"], "irrelevant": []},
                               {"answer": "no", "reason": "a cyclist riding ahead gives no reason to brake hard"}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    res = CliRunner().invoke(app, ["augment", str(scene), "--llm", "queued:test", "--no-pictures",
                                   "--out", str(tmp_path / "aug")], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    asked = provider.requests[-1][-1]["content"]
    assert "a cyclist rides ahead" in asked and "stops abruptly" in asked  # the behavior, not the truck
    record = json.loads((tmp_path / "aug" / "01-truck-brakes-augment" / "augment.json").read_text())
    (added,) = record["additions"]
    # the judge's no is recorded beside the simulation's answer, never over it
    assert added["status"].startswith("verified") and added["holds"]
    assert "no cause of the behavior" in added["reason"] and "the simulation decides" in added["reason"]


def test_a_manipulation_scene_is_shown_a_manipulation_example(tmp_path, monkeypatch):
    # a manipulation scene was shown a cyclist swerving into a lane as the example of an addition
    pet = pet_door_path()
    folder = tmp_path / "run" / "scenarios" / "01-pet"
    assert run_path(pet, folder, pictures=False).verdict.feasible
    res, provider = _augment(monkeypatch, folder, {"add": [], "irrelevant": []}, "--out", str(tmp_path / "aug"))
    assert res.exit_code == 0, res.output
    prompt = provider.requests[0][-1]["content"].lower()
    assert "a guest is about to arrive for dinner" in prompt and '(such as "pet1")' in prompt
    assert not any(w in prompt for w in ("cyclist", "lane", "brake", "sedan"))
