"""How one candidate's test case becomes its record: a missed state counts as the policy's
failure only where the edited world still calls for the behavior (the reference robot shows it:
the causal check is not ``not_sufficient``); a collision counts in any world the scripted robot
survives."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from regen.falsify.candidate import Bench, _judged
from regen.falsify.record import ScriptedRun
from regen.harness.cases import CaseResult, TemplateCheck


def _bench(tmp_path: Path) -> Bench:
    return Bench(out=tmp_path, harness=SimpleNamespace(robot="ego"), db=None, robot=("ego",), policy="idm")


def _case(**over) -> CaseResult:
    fields = {"scenario": "c1", "status": "failed", "adversarial": True,
              "template": TemplateCheck(verified=True, status="verified"), **over}
    return CaseResult(**fields)


def _base() -> dict:
    return {"cid": "c1", "scenario": "01-light", "edits": [], "words": ["set traffic_light1.light_state = green"],
            "origin": "single", "by_model": False, "folder": "candidates/c1", "settings": {}}


@pytest.mark.parametrize("causal, expected", [("not_sufficient", "invalid"), ("caused", "failed"),
                                              ("confounded", "failed"), (None, "failed")])
def test_a_missed_state_counts_only_where_the_world_still_calls_for_the_behavior(tmp_path, causal, expected):
    scripted = ScriptedRun(status="verified", verified=True, causal=causal)
    rec = _judged(_bench(tmp_path), _base(), scripted, _case(cause="state_not_reached",
                                                               message="never reached: braking"), "c1")
    assert rec.status == expected
    if expected == "invalid":
        assert "does not call for" in rec.reason and "not_sufficient" in rec.reason


def test_a_collision_counts_even_where_the_behavior_is_not_called_for(tmp_path):
    scripted = ScriptedRun(status="verified", verified=True, causal="not_sufficient")
    rec = _judged(_bench(tmp_path), _base(), scripted,
                  _case(cause="collision", collision=True, collision_with="bicycle1", message="collision"), "c1")
    assert rec.status == "failed" and rec.policy.collision_with == "bicycle1"


def test_a_scripted_collision_makes_the_candidate_invalid_never_a_finding(tmp_path):
    scripted = ScriptedRun(status="verified", verified=True, causal="caused")
    case = _case(cause="collision", collision=True, collision_with="adult1",
                 template=TemplateCheck(verified=True, status="verified", collision=True))
    rec = _judged(_bench(tmp_path), _base(), scripted, case, "c1")
    assert rec.status == "invalid" and rec.scripted.collision
