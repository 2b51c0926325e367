"""``regen falsify`` in the manipulation domain through the same code: the cast's context objects
set, removed and added as what-if edits; random fails where the scripted controller verified,
scripted passes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from regen.falsify import run_falsify  # noqa: E402

pytestmark = pytest.mark.slow


def test_random_fails_where_the_scripted_arm_verified_and_scripted_passes(manipulation_run, tmp_path):
    bad = run_falsify(manipulation_run, "random", budget=2, out=tmp_path / "random", pictures=False,
                      param_budget=0)
    assert [c.words for c in bad.candidates] == [["remove pet1"], ["remove desk_lamp1"]]
    pet, lamp = bad.candidates
    assert pet.status == "invalid" and not pet.scripted.verified  # the cause gone: nothing to explain
    assert lamp.status == "failed" and lamp.scripted.verified and not lamp.scripted.collision
    (finding,) = bad.findings
    assert finding.edits == ["remove desk_lamp1"] and finding.policy.cause == "time_budget"
    tests = json.loads(Path(finding.tests).read_text())
    assert tests["domain"] == "manipulation" and tests["cases"][0]["template"]["verified"]
    assert bad.robot == "robot arm"

    good = run_falsify(manipulation_run, "scripted", budget=3, out=tmp_path / "scripted", pictures=False,
                       param_budget=0)
    assert good.candidates[2].words == ["set desk_lamp1.power = off"]
    assert not good.findings and {c.status for c in good.candidates} == {"invalid", "passed"}
