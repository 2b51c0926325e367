"""`regen eval --coverage`: run folders (also batch and falsify folders) counted into the driving
typology per behavior, unverified scenarios left out, coverage.json and coverage.png written,
and folders that are no runs refused."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from regen.contract import Typology, TypologyCause, TypologyClass
from regen.core.behavior import Behavior
from regen.core.io import write_json
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.core.trace import ActorTrack, Trace
from regen.core.verdict import Verdict
from regen.errors import ConfigError
from regen.evaluation.cli import make_app
from regen.evaluation.coverage import coverage, find_runs

runner = CliRunner()
STOP = "the ego-vehicle stops abruptly while driving forward"
LANE = "the ego-vehicle changes lanes while driving forward"
DT, N = 0.1, 100


def _track(asset: str, x, y, heading: float, speed, kind: str = "agent", size=(4.6, 1.9)) -> ActorTrack:
    full = [np.broadcast_to(np.asarray(v, float), (N,)).tolist() for v in (x, y, heading, speed)]
    return ActorTrack(asset=asset, kind=kind, length=size[0], width=size[1], x=full[0], y=full[1],
                      heading=full[2], speed=full[3])


def _ego(v: float = 10.0) -> ActorTrack:
    return _track("ego", np.arange(N) * DT * v, -1.75, 0.0, v, kind="ego")


#: what each kind of scenario holds besides the ego: name -> (asset, track)
OTHERS = {
    "pedestrian": ("adult", _track("adult", 50.0, np.clip(-8 + 1.5 * np.arange(N) * DT, -8, 8), math.pi / 2, 1.5,
                                   size=(0.5, 0.5))),
    "stopped_car": ("sedan", _track("sedan", 60.0, -1.75, 0.0, 0.0)),
    "roadside": ("adult", _track("adult", 50.0, -8.0, 0.0, 0.0, size=(0.5, 0.5))),  # shows no class
}


def write_scenario(run: Path, name: str, behavior: str, other: str, status: str = "verified",
                   domain: str = "driving") -> None:
    asset, track = OTHERS[other]
    fsm = FSM(states=[AbstractState(name="moving", actor="ego", all_of=[PredicateCall(name="moving", args=["ego"])])],
              stages=[Stage(conditions=[StateRef(actor="ego", state="moving")])])
    b = Behavior(text=behavior, domain=domain)
    scenario = Scenario(id=name, domain=domain, behavior=b, causal_graph=[other, behavior], narrative=other,
                        entities=[Entity(name="ego", asset="ego", kind="robot"), Entity(name="a1", asset=asset)], fsm=fsm)
    folder = run / "scenarios" / name
    write_json(folder / "scenario.json", {"scenario": scenario.model_dump(mode="json"), "config": {}})
    write_json(folder / "trace.json", Trace(dt=DT, times=(np.arange(N) * DT).tolist(),
                                            actors={"ego": _ego(), "a1": track}, meta={"map": "straight"}))
    feasible = status in ("verified", "verified_after_relaxation")
    write_json(folder / "verdict.json", Verdict(feasible=feasible, status=status, reason="r"))


def make_run(run: Path, behavior: str, scenarios: dict[str, tuple[str, str]], domain: str = "driving") -> Path:
    """A run folder: run.json, then per scenario name (kind of scenario, verdict status)."""
    write_json(run / "run.json", {"behavior": {"text": behavior, "domain": domain, "params": {}},
                                  "settings": {}, "status": "done", "scenarios": list(scenarios)})
    for name, (other, status) in scenarios.items():
        write_scenario(run, name, behavior, other, status, domain)
    return run


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    return make_run(tmp_path / "run", STOP, {
        "01-ped": ("pedestrian", "verified"), "02-car": ("stopped_car", "verified_after_relaxation"),
        "03-ped-failed": ("pedestrian", "fsm_incomplete"), "04-roadside": ("roadside", "verified")})


def test_cli_prints_the_table_and_writes_coverage_json_and_png(run_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = runner.invoke(make_app(), ["eval", "--coverage", str(run_dir), "--out", str(out)], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "NHTSA pre-crash typology coverage (driving): 2 of 37 classes" in res.output
    assert "Pedestrian crash without prior vehicle maneuver" in res.output and "left out: 1" in res.output
    assert "fsm_incomplete: 1" in res.output
    data = json.loads((out / "coverage.json").read_text())
    (typ,) = data["typologies"]
    (b,) = typ["behaviors"]
    assert b["behavior"] == STOP and b["verified"] == 3 and b["left_out"] == 1 and b["unclassified"] == 1
    assert b["counts"] == {"pedestrian_without_maneuver": 1, "lead_vehicle_stopped": 1}
    assert "pedestrian_with_maneuver" in b["uncovered"] and "vehicle_failure" in b["not_simulable"]
    assert b["fill"]["lead_vehicle_decelerating"] == ["the car ahead brakes hard"]
    assert "pedestrian_with_maneuver" not in b["fill"]  # no cause of it fits an ego going straight
    assert [x["reason"] for x in typ["left_out"]] == ["fsm_incomplete"]
    why = {s["scenario"]: s["why"] for s in typ["scenarios"]}
    assert "a1 (adult)" in why["01-ped"]["pedestrian_without_maneuver"][0] and why["04-roadside"] == {}
    png = (out / "coverage.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    assert data["files"] == [str(out / "coverage.png"), str(out / "coverage.json")]


def test_without_out_nothing_is_written_and_the_user_is_told_how(run_dir: Path) -> None:
    res = runner.invoke(make_app(), ["eval", "--coverage", str(run_dir)], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "give --out FOLDER" in res.output and not (run_dir / "coverage.json").exists()


def test_a_batch_folder_counts_each_run_and_merges_runs_of_one_behavior(tmp_path: Path) -> None:
    batch = tmp_path / "batch"
    make_run(batch / "01-stop", STOP, {"a": ("pedestrian", "verified")})
    make_run(batch / "02-stop-again", STOP, {"a": ("stopped_car", "verified")})
    make_run(batch / "03-lane", LANE, {"a": ("stopped_car", "verified")})
    make_run(batch / "04-door", "the robot opens the door", {}, domain="manipulation")
    (batch / "batch.json").write_text("{}")
    report = coverage([batch])
    assert [Path(r).name for r in report.runs] == ["01-stop", "02-stop-again", "03-lane", "04-door"]
    (typ,) = report.typologies
    by = {b.behavior: b for b in typ.behaviors}
    assert set(by) == {STOP, LANE} and len(by[STOP].runs) == 2
    assert by[STOP].counts == {"pedestrian_without_maneuver": 1, "lead_vehicle_stopped": 1}
    assert by[LANE].counts == {"lead_vehicle_stopped": 1}
    assert typ.covered == ["pedestrian_without_maneuver", "lead_vehicle_stopped"]
    assert report.skipped == {}  # the manipulation run has no scenarios to count


def test_falsify_candidates_two_levels_down_are_runs(tmp_path: Path) -> None:
    out = tmp_path / "falsify"
    make_run(out / "candidates" / "c1", STOP, {"c1": ("stopped_car", "verified")})
    (out / "falsify.json").write_text("{}")
    assert find_runs([out]) == [out / "candidates" / "c1"]
    assert coverage([out]).typologies[0].behaviors[0].counts == {"lead_vehicle_stopped": 1}


def test_a_run_of_a_domain_without_typology_is_named_not_counted(tmp_path: Path) -> None:
    run = make_run(tmp_path / "door", "the robot opens the door", {"a": ("roadside", "verified")},
                   domain="manipulation")
    report = coverage([run])
    assert report.typologies == [] and "no scenario typology" in report.skipped["the robot opens the door"]
    res = runner.invoke(make_app(), ["eval", "--coverage", str(run)], env={"COLUMNS": "200"})
    assert res.exit_code == 0 and "nothing was counted" in res.output


@pytest.mark.parametrize("make,message", [
    (lambda p: p.mkdir(), "is not a run folder (no run.json and no scenarios/ folder) and holds none"),
    (lambda p: p.write_text("x"), "is a file, not a run folder"),
    (lambda p: None, "does not exist"),
])
def test_a_folder_that_is_no_run_is_one_clear_error(tmp_path: Path, make, message) -> None:
    target = tmp_path / "notarun"
    make(target)
    res = runner.invoke(make_app(), ["eval", "--coverage", str(target)], env={"COLUMNS": "300"})
    assert res.exit_code == 2, res.output
    assert message in res.output and "Traceback" not in res.output
    with pytest.raises(ConfigError, match="run folder"):
        coverage([target])


def test_coverage_without_folders_says_what_to_give() -> None:
    res = runner.invoke(make_app(), ["eval", "--coverage"], env={"COLUMNS": "300"})
    assert res.exit_code == 2 and "--coverage needs run folders" in res.output


class _Letters(Typology):
    """A typology whose classes are the first letter of the scenario's other entity's asset."""

    def __init__(self):
        super().__init__("letters", [
            TypologyClass("a", 1, "A", "asset starts with a", causes=(TypologyCause("an a", ("stop",)),)),
            TypologyClass("s", 2, "S", "asset starts with s"),
            TypologyClass("z", 3, "Z", "never", simulable=False)])

    def explain(self, scenario, trace):
        return {e.asset[0]: [e.name] for e in scenario.entities if not e.is_robot and e.asset[0] in "asz"}

    def behavior_key(self, behavior):
        return "stop"


def test_counting_follows_the_domains_typology_only(tmp_path: Path) -> None:
    run = make_run(tmp_path / "run", STOP, {"p": ("pedestrian", "verified"), "c": ("stopped_car", "verified"),
                                            "x": ("stopped_car", "unfaithful")})
    report = coverage([run], typology_of=lambda domain: _Letters())
    (b,) = report.typologies[0].behaviors
    assert b.counts == {"a": 1, "s": 1} and b.left_out == 1
    assert b.uncovered == [] and b.not_simulable == ["z"] and b.fill == {}
    run2 = make_run(tmp_path / "run2", STOP, {"c": ("stopped_car", "verified")})
    (b,) = coverage([run2], typology_of=lambda domain: _Letters()).typologies[0].behaviors
    assert b.uncovered == ["a"] and b.fill == {"a": ["an a"]}
