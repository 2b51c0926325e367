"""``regen falsify`` in the manipulation domain through the same code: the cast's context objects
set, removed and added as what-if edits; random fails the scenario as generated where the scripted
controller verified (its finding has no edit, and its edits are not searched), scripted passes
the scenario and its edits."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from regen.falsify import run_falsify  # noqa: E402
from regen.falsify.candidate import NO_EDIT  # noqa: E402

pytestmark = pytest.mark.slow


def test_random_fails_where_the_scripted_arm_verified_and_scripted_passes(manipulation_run, tmp_path):
    bad = run_falsify(manipulation_run, "random", budget=3, out=tmp_path / "random", pictures=False,
                      param_budget=0)
    (baseline,) = bad.candidates  # random fails as generated: none of the scene's edits is tried
    assert baseline.origin == "baseline" and baseline.edits == [] and baseline.words == [NO_EDIT]
    assert baseline.status == "failed" and baseline.scripted.verified and not baseline.scripted.collision
    (finding,) = bad.findings
    assert finding.edit_list == [] and finding.edits == [NO_EDIT] and finding.minimal
    assert finding.policy.cause == "time_budget" and bad.sources[0]["baseline"] == "failed"
    tests = json.loads(Path(finding.tests).read_text())
    assert tests["domain"] == "manipulation" and tests["cases"][0]["template"]["verified"]
    assert bad.robot == "robot arm"

    good = run_falsify(manipulation_run, "scripted", budget=4, out=tmp_path / "scripted", pictures=False,
                       param_budget=0)
    assert [c.words for c in good.candidates] == [[NO_EDIT], ["remove pet1"], ["remove desk_lamp1"],
                                                  ["set desk_lamp1.power = off"]]
    first, pet = good.candidates[:2]
    assert first.origin == "baseline" and first.status == "passed" and good.sources[0]["baseline"] == "passed"
    assert pet.status == "invalid" and not pet.scripted.verified  # the cause gone: nothing to explain
    assert not good.findings and {c.status for c in good.candidates} == {"invalid", "passed"}
