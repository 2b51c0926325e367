"""The shared policy harness: what any domain gets, and that it names none."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from line_harness import LineHarness, line_scenario, line_trace

from regen import domains
from regen.errors import ConfigError
from regen.harness.cases import CaseResult, SuiteReport
from regen.harness.contract import Episode, PolicyHarness
from regen.harness.junit import junit_xml
from regen.harness.oracle import judge
from regen.harness.suite import harness_for

SRC = Path(__file__).resolve().parents[2] / "src" / "regen"


def test_a_domain_without_a_harness_is_told_clearly():
    domains.register("aisle", "toydomain:AisleBackend")
    try:
        with pytest.raises(ConfigError, match="aisle domain has no policy harness"):
            harness_for("aisle")
    finally:
        domains.unregister("aisle")


def test_every_registered_domain_has_a_harness():
    for name in domains.names():
        assert isinstance(harness_for(name), PolicyHarness), name


def test_tests_json_written_before_the_shared_harness_still_loads():
    old = {"scenario": "01-x", "status": "failed", "cause": "ego_state_not_reached",
           "ego_stages": [{"conditions": ["braking"], "reached_at": 1.5}, {"conditions": ["stopped"]}]}
    case = CaseResult.model_validate(old)
    assert [s.conditions for s in case.robot_stages] == [["braking"], ["stopped"]]
    assert case.robot_stages[0].reached_at == 1.5
    assert "robot_stages" in case.model_dump() and "ego_stages" not in case.model_dump()


DOMAIN_WORDS = re.compile(r"\b(driving|manipulation|ego|vehicle|pedestrian|scenic|pybullet|panda|door)\b",
                          re.IGNORECASE)


def _code(text: str) -> str:
    """The text without docstrings and comments (examples there may name a domain)."""
    text = re.sub(r'"""(?:.|\n)*?"""', "", text)
    return "\n".join(line.split("#", 1)[0] for line in text.splitlines())


@pytest.mark.parametrize("path", sorted((SRC / "harness").glob("*.py")) + [
    SRC / "report" / "templates" / "behavior_tests.html.j2", SRC / "report" / "tests_view.py"],
    ids=lambda p: p.name)
def test_the_shared_harness_names_no_domain(path: Path):
    text = path.read_text(encoding="utf-8")
    found = sorted({m.group(0).lower() for m in DOMAIN_WORDS.finditer(_code(text) if path.suffix == ".py" else text)})
    assert not found, f"{path.name} names {found}"


# --- the generic oracle with a tiny harness over a hand-made trace --------------------------------


_Line = LineHarness
_scenario = line_scenario
_trace = line_trace


def test_the_oracle_fails_a_collision_first_and_passes_a_clean_run(monkeypatch):
    import regen.verify.monitor as monitor

    monkeypatch.setattr(monitor, "evaluate_state", lambda state, trace, domain:
                        __import__("numpy").asarray(trace.actors["r"].x) >= 5.0)
    h, sc = _Line(), _scenario()
    crash = judge(h, sc, Episode(trace=_trace([0, 3, 6, 9])), folder="s")
    assert crash.status == "failed" and crash.cause == "collision" and crash.collision_with == "box"
    assert crash.message == "collision: the robot hit box at t=3.0 s"
    ok = judge(h, sc, Episode(trace=_trace([0, 3, 6, 7])), folder="s")
    assert ok.status == "passed" and ok.robot_stages[0].reached_at == 2.0
    short = judge(h, sc, Episode(trace=_trace([0, 1, 2, 3])), folder="s")
    assert short.cause == "state_not_reached" and "state 1 of 1" in short.message
    faulty = judge(h, sc, Episode(trace=None, failure="boom", failure_kind="exception"), folder="s")
    assert faulty.cause == "policy_exception" and "boom" in faulty.message
    xml = junit_xml(SuiteReport(run="/tmp/r", policy="p", domain="line", cases=[crash, ok]))
    assert 'classname="regen.line.r"' in xml and 'type="collision"' in xml
