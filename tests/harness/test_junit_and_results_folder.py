"""``regen test`` on a tiny run folder with a policy in its own process (:mod:`printing_harness`):
junit.xml reads as a report (the reason as the failure's message, a readable body, what the
policy printed during each case and its picture as an attachment), and a policy that does not
load leaves nothing behind."""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from line_harness import line_scenario
from printing_harness import PrintingHarness
from typer.testing import CliRunner

import regen.harness.suite as suite
from regen.cli import app
from regen.core.io import write_json
from regen.core.verdict import Verdict
from regen.harness.cases import CaseResult, SuiteReport
from regen.harness.junit import failure_text, junit_xml

SUPPORT = Path(__file__).resolve().parents[1] / "support"


@pytest.fixture
def run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A run folder with two verified scenarios: '01-crash' (the robot hits the box) and '02-fine'."""
    import regen.verify.monitor as monitor

    monkeypatch.setattr(monitor, "evaluate_state", lambda state, trace, domain:
                        np.asarray(trace.actors["r"].x) >= 5.0)
    monkeypatch.setattr(suite, "harness_for", lambda domain: PrintingHarness())
    # the policy's process imports the harness as this one does
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(SUPPORT), os.environ.get("PYTHONPATH", "")]))
    folder = tmp_path / "run"
    for name in ("01-crash", "02-fine"):
        scenario = line_scenario(name, causes=("a box",))
        write_json(folder / "scenarios" / name / "scenario.json", {"scenario": scenario.model_dump(mode="json")})
        write_json(folder / "scenarios" / name / "verdict.json",
                   Verdict(feasible=True, status="verified", reason="ok"))
    write_json(folder / "run.json", {"behavior": {"text": "it moves", "domain": "line"},
                                     "scenarios": ["01-crash", "02-fine"]})
    return folder


def _test(*args: str):
    return CliRunner().invoke(app, ["test", *args], env={"COLUMNS": "200"})


def _cases(junit: Path) -> dict[str, ET.Element]:
    root = ET.parse(junit).getroot()  # well-formed, or this raises
    return {tc.get("name"): tc for tc in root.iter("testcase")}


def test_junit_says_what_failed_when_with_the_policys_output_and_its_picture(run: Path) -> None:
    res = _test(str(run), "--policy", "steady")
    assert res.exit_code == 1, res.output  # one failed
    out = run / "tests" / "steady"
    cases = _cases(out / "junit.xml")
    crash, fine = cases["01-crash[variant 0]"], cases["02-fine[variant 0]"]
    failure = crash.find("failure")
    assert failure.get("message") == "collision: the robot hit box at t=3.0 s"  # the reason, as CI shows it
    assert failure.get("type") == "collision"
    body = failure.text
    assert not body.lstrip().startswith("{") and '"scenario_id"' not in body  # no JSON dump
    gif = out / "01-crash-v0" / "failure.gif"
    assert gif.is_file()
    for line in ("what happened: collision: the robot hit box at t=3.0 s", "when: t=3.0 s",
                 "scenario: 01-crash, variant 0", "collision with: box", f"picture: {gif}",
                 f"trace: {out / '01-crash-v0' / 'trace.json'}"):
        assert line in body.splitlines() or any(ln.startswith(line) for ln in body.splitlines()), (line, body)
    printed = crash.find("system-out").text
    assert "steady policy saw 01-crash" in printed and "steady policy warns about 01-crash" in printed
    assert "02-fine" not in printed  # each case shows what the policy printed during it
    assert f"[[ATTACHMENT|{gif}]]" in printed.splitlines()  # Jenkins / GitLab attachments
    assert Path(gif).is_absolute()
    assert fine.find("failure") is None and "steady policy saw 02-fine" in fine.find("system-out").text
    assert "ATTACHMENT" not in fine.find("system-out").text

    # a rerun keeps the finished cases, and what their policy printed stays with them
    res = _test(str(run), "--policy", "steady")
    assert res.exit_code == 1, res.output
    again = _cases(out / "junit.xml")
    assert "steady policy saw 01-crash" in again["01-crash[variant 0]"].find("system-out").text
    assert "steady policy saw 02-fine" in again["02-fine[variant 0]"].find("system-out").text


def test_junit_body_without_a_results_folder_and_with_hostile_output() -> None:
    case = CaseResult(scenario="01-x", status="failed", cause="policy_exception", simulated=2.0,
                      message="policy failed at t=1.5 s: ValueError: no", gif="01-x-v0/failure.gif")
    text = failure_text(case)
    assert text.splitlines()[:2] == ["what happened: policy failed at t=1.5 s: ValueError: no",
                                     "when: the episode ran 2.0 s of simulated time"]
    assert "picture: 01-x-v0/failure.gif" in text
    xml = junit_xml(SuiteReport(run="/tmp/r", policy="p", cases=[case]),
                    logs={"01-x-v0": "bell\x07 and ]]> and <tag> and \ud800"})
    root = ET.fromstring(xml.split("\n", 1)[1])  # valid XML whatever the policy printed
    out = root.find(".//system-out").text
    assert "]]> and <tag>" in out and "ATTACHMENT" not in out  # no folder known: no attachment


def test_a_policy_that_does_not_load_leaves_nothing_behind(run: Path, tmp_path: Path) -> None:
    res = _test(str(run), "--policy", "nosuch")
    assert res.exit_code == 2, res.output
    assert "unknown policy 'nosuch'" in res.output and "steady" in res.output
    assert not (run / "tests").exists()  # not RUN/tests/nosuch, nor RUN/tests
    elsewhere = tmp_path / "results" / "deep" / "nosuch"
    res = _test(str(run), "--policy", "nosuch", "--out", str(elsewhere))
    assert res.exit_code == 2 and not (tmp_path / "results").exists(), res.output
    res = _test(str(run), "--policy", "nosuch.py")
    assert res.exit_code == 2 and "does not exist" in res.output and not (run / "tests").exists()


def test_a_refused_policy_leaves_earlier_results_as_they_were(run: Path) -> None:
    out = run / "tests" / "steady"
    assert _test(str(run), "--policy", "steady").exit_code == 1
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    res = _test(str(run), "--policy", "nosuch", "--out", str(out))
    assert res.exit_code == 2, res.output
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert {k: v for k, v in after.items() if k.name != "policy.log"} == \
        {k: v for k, v in before.items() if k.name != "policy.log"}
    assert json.loads((out / "settings.json").read_text())["policy"] == "steady"
