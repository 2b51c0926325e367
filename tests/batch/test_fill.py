"""`regen batch --fill-coverage` on the fake simulator and a scripted model: after the spec's
behaviors, one run per cause that presents a typology class a behavior leaves uncovered; the
summary says what the fill added; a rerun resumes the same fill runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fake_backend import FakeBackend
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.batch import run_batch
from regen.cli import app
from regen.contract import Typology, TypologyCause, TypologyClass
from regen.llm import registry
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly while driving forward"


class _AssetTypology(Typology):
    """Classes by the asset of the scenario's cause entity; causes that fit 'stop' behaviors."""

    def __init__(self):
        super().__init__("assets", [
            TypologyClass("debris", 1, "Debris", "debris in the way", causes=(TypologyCause("debris lies ahead", ("stop",)),)),
            TypologyClass("cyclist", 2, "Cyclist", "a cyclist in the way",
                          causes=(TypologyCause("a cyclist rides ahead", ("stop",)),)),
            TypologyClass("lane", 3, "Lane", "fits no stop", causes=(TypologyCause("a lane closes", ("lane",)),)),
            TypologyClass("never", 4, "Never", "cannot be simulated", simulable=False)])

    def explain(self, scenario, trace):
        names = {"debris": "debris", "bicycle": "cyclist"}
        return {names[e.asset]: [e.name] for e in scenario.entities if e.asset in names}

    def behavior_key(self, behavior):
        return "stop" if "stop" in behavior.text else None


class _TypedFake(FakeBackend):
    def typology(self):
        return _AssetTypology()


@pytest.fixture
def fake_driving(monkeypatch):
    entry = f"{__name__}:_TypedFake"
    monkeypatch.setitem(domains._REGISTRY, "driving", entry)
    monkeypatch.setitem(domains._LOADED, entry, _TypedFake)
    FakeBackend.simulated = []
    model = ScriptedModel(causes={STOP: ["a bus blocks the lane"]},  # the bus never makes the ego stop
                          entities={"a bus blocks the lane": ["bus"], "debris lies ahead": ["debris"],
                                    "a cyclist rides ahead": ["bicycle"]})
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
    return model


def _spec(tmp_path: Path) -> Path:
    p = tmp_path / "spec.yaml"
    p.write_text(f"behaviors:\n  - text: {STOP}\n    domain: driving\n    scenarios: 1\n    llm: scripted\n"
                 "    depth: 1\n    pictures: false\n")
    return p


def test_fill_runs_a_cause_per_uncovered_class_and_the_summary_says_what_it_added(tmp_path, fake_driving):
    out = tmp_path / "batch"
    rec = run_batch(_spec(tmp_path), out, workers=1, fill_coverage=True)
    assert rec.status == "done", rec.message
    folders = [b.folder for b in rec.behaviors]
    assert folders == ["01-the-ego-vehicle-stops-abruptly-while-dri", "01-fill-1-debris-lies-ahead",
                       "01-fill-2-a-cyclist-rides-ahead"]
    fill = rec.behaviors[1]
    assert fill.fill_of == folders[0] and fill.fill_cause == "debris lies ahead" and fill.fill_classes == ["debris"]
    run = json.loads((out / folders[1] / "run.json").read_text())
    assert run["behavior"]["text"] == STOP
    assert run["settings"]["forced_causes"] == ["debris lies ahead"] and run["settings"]["max_scenarios"] == 1
    summary = json.loads((out / "summary.json").read_text())
    (f,) = summary["fill"]
    assert f["folder"] == folders[0] and f["before"] == [] and f["added"] == ["1 Debris", "2 Cyclist"]
    assert [(r["cause"], r["covered"], r["verified"]) for r in f["runs"]] == [
        ("debris lies ahead", ["1 Debris"], 1), ("a cyclist rides ahead", ["2 Cyclist"], 1)]
    assert [b["fill_of"] for b in summary["behaviors"]] == [None, folders[0], folders[0]]
    # a rerun plans the same fill runs and resumes them: no model call, nothing simulated again
    calls, simulated = len(fake_driving.kinds), len(FakeBackend.simulated)
    again = run_batch(_spec(tmp_path), out, workers=1, fill_coverage=True)
    assert [b.folder for b in again.behaviors] == folders and again.status == "done"
    assert len(fake_driving.kinds) == calls and len(FakeBackend.simulated) == simulated
    # without --fill-coverage the fill runs stay recorded (and the folder is still the batch's own)
    plain = run_batch(_spec(tmp_path), out, workers=1)
    assert [b.folder for b in plain.behaviors] == folders


def test_without_fill_nothing_extra_runs_and_the_cli_prints_the_fill(tmp_path, fake_driving):
    out = tmp_path / "batch"
    rec = run_batch(_spec(tmp_path), out, workers=1)
    assert len(rec.behaviors) == 1 and json.loads((out / "summary.json").read_text())["fill"] == []
    res = CliRunner().invoke(app, ["batch", str(_spec(tmp_path)), "--out", str(out), "--log", "quiet",
                                   "--fill-coverage", "--workers", "1"], env={"COLUMNS": "300"})
    assert res.exit_code == 0, res.output
    assert "fill 01-the-ego-vehicle-stops-abruptly-while-dri: 2 extra run(s), typology classes 0 -> 2, " \
           "added: 1 Debris; 2 Cyclist" in res.output


def test_the_batch_report_shows_the_fill(tmp_path, fake_driving):
    out = tmp_path / "batch"
    run_batch(_spec(tmp_path), out, workers=1, fill_coverage=True)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert 'id="fill"' in page and "1 Debris, 2 Cyclist" in page
    assert "(coverage fill: debris lies ahead)" in page


def test_the_progress_lines_say_which_fill_runs_were_added(tmp_path, fake_driving):
    out = tmp_path / "batch"
    res = CliRunner().invoke(app, ["batch", str(_spec(tmp_path)), "--out", str(out), "--fill-coverage",
                                   "--workers", "1"], env={"COLUMNS": "300"})
    assert res.exit_code == 0, res.output
    assert ("coverage fill: 2 run(s) added: 01-fill-1-debris-lies-ahead, 01-fill-2-a-cyclist-rides-ahead"
            in res.output)
    assert "01-fill-1-debris-lies-ahead: started" in res.output  # each fill run then shows as a behavior
    again = CliRunner().invoke(app, ["batch", str(_spec(tmp_path)), "--out", str(out), "--fill-coverage",
                                     "--workers", "1"], env={"COLUMNS": "300"})
    assert again.exit_code == 0 and "coverage fill: 2 run(s) added" in again.output  # resumed, the same runs


def test_a_fill_that_adds_nothing_says_so():
    from regen.batch.progress import _Tally

    tally = _Tally()
    assert tally.take({"event": "fill", "runs": []}) == \
        "coverage fill: no run to add (no uncovered class has a cause that fits)"
    assert tally.rows == {}
