"""Each test case carries its scenario's causal check (read from the scenario folder's
verdict.json when the test runs), so that a failure on a confounded scenario is explained:
in the case, in tests.json, and on the terminal line. Older tests.json files still load."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import regen.harness.suite as suite
from regen.core.io import write_json
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.core.trace import ActorTrack, Trace
from regen.core.verdict import Causal, Verdict
from regen.harness.cases import CaseResult, case_line
from regen.harness.contract import Episode, Incident, PolicyHarness, TemplateRun

OLD_KEYS = {"scenario", "scenario_id", "variant", "status", "cause", "message", "collision", "collision_with",
            "collision_time", "min_ttc", "min_distance", "metrics", "infractions", "robot_stages", "simulated",
            "wall", "gif", "parameters", "adversarial", "template"}


def test_a_case_has_an_optional_causal_field_and_old_files_load() -> None:
    old = CaseResult.model_validate({"scenario": "01-x", "status": "failed", "cause": "collision"})
    assert old.causal is None
    dumped = old.model_dump(mode="json")
    assert set(dumped) == OLD_KEYS | {"causal"}  # only added, nothing renamed or dropped
    case = CaseResult(scenario="01-x", status="failed", cause="state_not_reached", message="state 2 never held",
                      causal="confounded: traffic_light1")
    assert CaseResult.model_validate_json(case.model_dump_json()).causal == "confounded: traffic_light1"


def test_the_terminal_line_shows_the_causal_check() -> None:
    case = CaseResult(scenario="01-x", status="failed", cause="state_not_reached", message="state 2 never held",
                      causal="confounded: traffic_light1")
    assert case_line(case) == "FAIL  01-x  state 2 never held  [causal: confounded: traffic_light1]"
    case.causal = None
    assert case_line(case) == "FAIL  01-x  state 2 never held"


# --- regen test on a tiny run folder --------------------------------------------------------------


class _Line(PolicyHarness):
    """A robot on a line that must reach x >= 5; it reaches x = 6, unless the scenario's id says
    'crash', where it runs into the box at x = 8."""

    robot = "robot"

    def load_policy(self, spec):
        raise NotImplementedError

    def action_to_wire(self, action):
        return [float(action)]

    def action_from_wire(self, data):
        return data[0]

    def prepare(self, scenario):
        return scenario

    def run_policy(self, prepared, policy, *, step_timeout):
        xs = [0.0, 3.0, 6.0, 9.0] if "crash" in prepared.id else [0.0, 3.0, 6.0, 6.5]
        n = len(xs)
        track = ActorTrack(asset="bot", x=xs, y=[0.0] * n, heading=[0.0] * n, speed=[1.0] * n, length=1.0,
                           width=1.0)
        box = ActorTrack(asset="box", x=[8.5] * n, y=[0.0] * n, heading=[0.0] * n, speed=[0.0] * n, length=1.0,
                         width=1.0)
        return Episode(trace=Trace(dt=1.0, times=[float(k) for k in range(n)], actors={"r": track, "box": box}))

    def incidents(self, scenario, trace):
        x = trace.actors["r"].x
        hit = next((k for k, v in enumerate(x) if v >= 8.0), None)
        return [] if hit is None else [Incident("collision", trace.times[hit], hit, ("r", "box"),
                                                "r touched box", collision=True)]

    def sample_variants(self, scenario, n, seed, *, extremes=False):
        return [scenario]

    def check_template(self, scenario):
        return TemplateRun(verdict=None)


def _scenario(sid: str) -> Scenario:
    far = AbstractState(name="far", actor="r", all_of=[PredicateCall(name="moving", args=["r"])])
    fsm = FSM(states=[far], stages=[Stage(conditions=[StateRef(actor="r", state="far")])])
    return Scenario(id=sid, domain="line", behavior={"text": "it moves", "domain": "line"},
                    causal_graph=["a box", "it moves"], narrative="",
                    entities=[Entity(name="r", asset="bot", kind="robot"), Entity(name="box", asset="box", kind="object")],
                    fsm=fsm)


def _verdict(ok: bool, causal: Causal | None) -> Verdict:
    return Verdict(feasible=ok, status="verified" if ok else "fsm_incomplete", reason="ok" if ok else "no",
                   causal=causal)


@pytest.fixture
def line_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    import regen.verify.monitor as monitor

    monkeypatch.setattr(monitor, "evaluate_state", lambda state, trace, domain:
                        np.asarray(trace.actors["r"].x) >= 5.0)
    monkeypatch.setattr(suite, "harness_for", lambda domain: _Line())
    run = tmp_path / "run"
    specs = {"01-crash": (True, Causal(status="confounded", reason="the box alone explains it",
                                       confounders=["traffic_light1"])),
             "02-caused": (True, Causal(status="caused", reason="the reference robot moves for the box only")),
             "03-old": (True, None),  # a verdict.json from before the causal check
             "04-infeasible": (False, Causal(status="not_checked", reason="the scenario did not verify"))}
    for name, (ok, causal) in specs.items():
        write_json(run / "scenarios" / name / "scenario.json", {"scenario": _scenario(name).model_dump(mode="json")})
        write_json(run / "scenarios" / name / "verdict.json", _verdict(ok, causal))
    write_json(run / "run.json", {"behavior": {"text": "it moves", "domain": "line"}, "scenarios": list(specs)})
    return run


def test_run_tests_records_each_scenarios_causal_check(line_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    report = suite.run_tests(line_run, "inline", policy=lambda obs: 1.0, out=out)
    by = {c.scenario: c for c in report.cases}
    assert (by["01-crash"].status, by["01-crash"].cause) == ("failed", "collision")
    assert by["01-crash"].causal == "confounded: traffic_light1"
    assert (by["02-caused"].status, by["02-caused"].causal) == ("passed", "caused")
    assert by["03-old"].status == "passed" and by["03-old"].causal is None
    assert (by["04-infeasible"].status, by["04-infeasible"].causal) == ("skipped", "not_checked")
    rows = {r["scenario"]: r for r in json.loads((out / "tests.json").read_text())["cases"]}
    assert rows["01-crash"]["causal"] == "confounded: traffic_light1" and rows["03-old"]["causal"] is None
    assert OLD_KEYS <= set(rows["01-crash"])  # the old fields are all still there
    assert "[causal: confounded: traffic_light1]" in case_line(by["01-crash"])
    # a rerun keeps the finished cases and their causal check
    again = suite.run_tests(line_run, "inline", policy=lambda obs: 1.0, out=out)
    assert {c.scenario: c.causal for c in again.cases} == {c.scenario: c.causal for c in report.cases}
