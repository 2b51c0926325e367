"""``regen falsify`` on a driving run built without a model: findings only where the scripted ego
verified and hit nothing, invalid candidates never reported as the policy's failures, replay,
resume, the model's causes and the search's order (pairs, shrinking) over fake candidates."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from falsify_runs import CHILD, OTHER_CAUSE

pytest.importorskip("scenic")

from regen.falsify import CandidateRecord, PolicyRun, ScriptedRun, run_falsify  # noqa: E402
from regen.runfolder import RunFolder  # noqa: E402

pytestmark = pytest.mark.slow


def test_a_policy_that_never_brakes_gets_findings_where_the_scripted_ego_verified(searched):
    out, report = searched
    assert report.status == "done" and report.tried == 3 and report.budget == 3
    assert [c.words for c in report.candidates] == [[f"add cause '{OTHER_CAUSE}'"], ["remove child1"],
                                                    ["set child1.behavior = stationary"]]
    assert report.findings, [c.reason for c in report.candidates]
    for f in report.findings:
        assert f.scripted.verified and not f.scripted.collision and f.policy.status == "failed"
        assert f.minimal and f.chain == [f.edits]
        tests = json.loads(Path(f.tests).read_text())  # written exactly as regen test writes it
        (case,) = tests["cases"]
        assert case["status"] == "failed" and case["adversarial"] and case["template"]["verified"]
        assert not case["template"]["collision"]
        assert (Path(f.folder) / RunFolder.MANIFEST).is_file() and Path(f.xosc).suffix == ".xosc"
        assert f.replay == f"regen test {f.folder} --policy constant-speed"
    added = report.findings[0]
    assert added.edits == [f"add cause '{OTHER_CAUSE}'"] and added.failure.startswith("collision with ")
    saved = json.loads((out / "falsify.json").read_text())
    assert saved["tried"] == 3 and len(saved["findings"]) == len(report.findings)
    assert saved["parameter_search"] == "parameter search not run: --param-budget 0"


def test_a_candidate_the_scripted_ego_does_not_survive_is_invalid_never_a_finding(searched):
    _, report = searched
    removed = next(c for c in report.candidates if c.words == ["remove child1"])
    assert removed.status == "invalid" and not removed.scripted.verified and removed.policy is None
    assert "does not verify" in removed.reason
    assert all(f.cid != removed.cid for f in report.findings)
    assert report.invalid >= 1


def test_a_candidate_in_which_the_scripted_ego_collides_is_invalid(driving_run, tmp_path, monkeypatch):
    """The scripted ego verifies but collides: regen test's adversarial check skips the case, and
    the candidate is invalid with that reason (the policy's failure there would be inevitable)."""
    from regen.harness import suite
    from regen.harness.cases import TemplateCheck

    real = suite._template_check

    def colliding(run):
        check = real(run)
        return TemplateCheck(verified=check.verified, status=check.status, collision=True,
                             message=f"{check.message}; the scripted ego collides: the ego hit child1")

    monkeypatch.setattr(suite, "_template_check", colliding)
    report = run_falsify(driving_run, "constant-speed", budget=1, out=tmp_path / "fz", pictures=False,
                         param_budget=0)
    (rec,) = report.candidates
    assert rec.scripted.verified and rec.scripted.collision and rec.status == "invalid"
    assert "collides" in rec.reason and not report.findings and report.failures == 0


def test_a_finding_replays_with_regen_test(searched):
    from regen.harness.suite import run_tests

    _, report = searched
    f = report.findings[0]
    again = run_tests(f.folder, "constant-speed")
    (case,) = again.cases
    assert case.status == "failed" and case.cause == f.policy.cause
    assert case.collision_with == f.policy.collision_with


def test_a_rerun_keeps_the_finished_candidates(searched, monkeypatch):
    from regen.falsify import candidate

    out, report = searched

    def never(*args, **kwargs):
        raise AssertionError("a finished candidate was run again")

    monkeypatch.setattr(candidate, "run_candidate", never)
    monkeypatch.setattr("regen.falsify.search.run_candidate", never)
    again = run_falsify(report.run, "constant-speed", budget=3, out=out, pictures=False, param_budget=0)
    assert again.kept == again.tried == 3 and all(c.kept for c in again.candidates)
    assert [f.cid for f in again.findings] == [f.cid for f in report.findings]


def test_the_model_s_causes_are_added_and_marked(driving_run, tmp_path, monkeypatch):
    from regen.llm import LLM, registry
    from regen.llm.testing import QueuedProvider

    provider = QueuedProvider([{"causes": ["a police car blocks the lane ahead", "the ego's brakes fail",
                                           OTHER_CAUSE]}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    llm = LLM("queued:test", cache=str(tmp_path / "cache.sqlite"))
    report = run_falsify(driving_run, "constant-speed", budget=2, out=tmp_path / "fz", llm=llm, pictures=False,
                         param_budget=0)
    prompt = provider.requests[0][-1]["content"]
    assert "constant-speed" in prompt and "child1" in prompt and OTHER_CAUSE in prompt  # tried causes named
    (asked,) = report.model
    assert asked.causes == ["a police car blocks the lane ahead"]
    assert set(asked.rejected) == {"the ego's brakes fail", OTHER_CAUSE}
    first, second = report.candidates
    assert first.origin == "single" and not first.by_model
    assert second.origin == "model" and second.by_model
    assert second.words == ["add cause 'a police car blocks the lane ahead'"]
    assert report.settings["llm"].startswith("queued")


def test_without_the_parameter_module_the_stage_says_why(searched, monkeypatch):
    out, report = searched
    monkeypatch.setitem(sys.modules, "regen.falsify.params", None)  # import fails
    again = run_falsify(report.run, "constant-speed", budget=3, out=out, pictures=False, param_budget=4)
    assert again.parameter_search.startswith("parameter search not run: ")
    assert all(f.parameter_search is None for f in again.findings)


# --- the search's order, over fake candidates ------------------------------------------------------------


def _fake(fails, ungroundable=lambda words: False):
    """A run_candidate that simulates nothing: a candidate fails when ``fails(words)``, cannot be
    grounded when ``ungroundable(words)``, else passes."""

    def run_candidate(bench, source, edits, *, origin="single", by_model=False):
        from regen.falsify.space import candidate_id, canonical

        edits = canonical(edits)
        words = [e.describe() for e in edits]
        if ungroundable(set(words)):
            return CandidateRecord(cid=candidate_id(source.name, edits), scenario=source.name, edits=edits,
                                   words=words, origin=origin, status="invalid", simulated=False,
                                   scripted=ScriptedRun(status="ungroundable"), settings=bench.settings)
        failed = fails(set(words))
        return CandidateRecord(cid=candidate_id(source.name, edits), scenario=source.name, edits=edits, words=words,
                               origin=origin, by_model=by_model, status="failed" if failed else "passed",
                               scripted=ScriptedRun(status="verified", verified=True, causal="caused"),
                               policy=PolicyRun(status="failed" if failed else "passed",
                                                cause="collision" if failed else None, collision=failed,
                                                collision_with="child1" if failed else None),
                               settings=bench.settings)

    return run_candidate


def test_pairs_come_after_every_single_and_a_failing_pair_is_minimal(driving_run, tmp_path, monkeypatch):
    fast, ahead = "set child1.target_speed = fast", "set child1.start_location = crosswalk_ahead"
    monkeypatch.setattr("regen.falsify.search.run_candidate", _fake(lambda w: {fast, ahead} <= w))
    report = run_falsify(driving_run, "constant-speed", budget=500, out=tmp_path / "fz", param_budget=0)
    sizes = [len(c.edits) for c in report.candidates]
    singles = sizes.count(1)
    assert sizes == [1] * singles + [2] * (len(sizes) - singles) and singles == 17  # breadth-first
    assert report.tried < 500  # every compatible pair tried, then the search ends
    (finding,) = report.findings
    assert set(finding.edits) == {fast, ahead} and finding.minimal and finding.scenario == CHILD
    pair = next(c for c in report.candidates if set(c.words) == {fast, ahead})
    assert pair.origin == "pair" and pair.minimal and pair.chain == [pair.cid]


def test_a_failing_single_is_the_finding_and_never_paired(driving_run, tmp_path, monkeypatch):
    fast = "set child1.target_speed = fast"
    monkeypatch.setattr("regen.falsify.search.run_candidate", _fake(lambda w: fast in w))
    report = run_falsify(driving_run, "constant-speed", budget=30, out=tmp_path / "fz", param_budget=0)
    assert [f.edits for f in report.findings] == [[fast]]
    assert not [c for c in report.candidates if len(c.edits) > 1 and fast in c.words]
    assert report.failures == 1


def test_a_candidate_that_cannot_be_grounded_does_not_count_against_the_budget(driving_run, tmp_path, monkeypatch):
    def placed(words):
        return any("start_location" in w for w in words)

    monkeypatch.setattr("regen.falsify.search.run_candidate", _fake(lambda w: False, ungroundable=placed))
    report = run_falsify(driving_run, "constant-speed", budget=8, out=tmp_path / "fz", param_budget=0)
    assert report.simulated == 8 and report.tried > 8
    assert all(not c.simulated for c in report.candidates if placed(c.words))


def test_ctrl_c_lets_the_candidate_finish_and_a_rerun_continues(driving_run, tmp_path, monkeypatch):
    import os
    import signal

    fake = _fake(lambda w: False)
    calls = []

    def interrupted(bench, source, edits, **kw):
        calls.append(edits)
        if len(calls) == 2:  # Ctrl-C in the middle of the second candidate: it still finishes
            os.kill(os.getpid(), signal.SIGINT)
        return fake(bench, source, edits, **kw)

    monkeypatch.setattr("regen.falsify.search.run_candidate", interrupted)
    out = tmp_path / "fz"
    with pytest.raises(KeyboardInterrupt):
        run_falsify(driving_run, "constant-speed", budget=4, out=out, param_budget=0)
    saved = json.loads((out / "falsify.json").read_text())
    assert saved["status"] == "interrupted" and saved["tried"] == 2
    monkeypatch.setattr("regen.falsify.search.run_candidate", fake)
    monkeypatch.setattr("regen.falsify.search.kept", _kept_from(saved))
    again = run_falsify(driving_run, "constant-speed", budget=4, out=out, param_budget=0)
    assert again.status == "done" and again.tried == 4 and again.kept == 2


def _kept_from(saved: dict):
    """kept() over the records of an interrupted search's falsify.json (the fake candidates wrote
    no folders of their own)."""
    records = {c["cid"]: CandidateRecord.model_validate(c) for c in saved["candidates"]}

    def kept(bench, cid):
        rec = records.get(cid)
        return rec.model_copy(update={"kept": True}) if rec is not None else None

    return kept
