"""Each test case carries its scenario's causal check (read from the scenario folder's
verdict.json when the test runs), so that a failure on a confounded scenario is explained:
in the case, in tests.json, and on the terminal line. Older tests.json files still load."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from line_harness import LineHarness, line_scenario, line_trace

import regen.harness.suite as suite
from regen.core.io import write_json
from regen.core.scenario import Scenario
from regen.core.verdict import Causal, Verdict
from regen.harness.cases import CaseResult, case_line
from regen.harness.contract import Episode

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


class _Line(LineHarness):
    """Reaches x = 6, unless the scenario's id says 'crash', where it runs into the box at x = 8."""

    def run_policy(self, prepared, policy, *, step_timeout):
        return Episode(trace=line_trace([0.0, 3.0, 6.0, 9.0] if "crash" in prepared.id else [0.0, 3.0, 6.0, 6.5]))


def _scenario(sid: str) -> Scenario:
    return line_scenario(sid, causes=("a box",))


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
