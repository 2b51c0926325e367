"""``regen falsify`` on a driving run built without a model: the baseline (the scenario as
generated, no edit) first, and a scenario the policy already fails is its own finding with its
edits not searched; findings only where the scripted ego verified and hit nothing, invalid
candidates never reported as the policy's failures, replay, resume, the model's causes and the
search's order (pairs, shrinking) over fake candidates."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from falsify_runs import CHILD, OTHER_CAUSE

pytest.importorskip("scenic")

from regen.falsify import CandidateRecord, PolicyRun, ScriptedRun, run_falsify  # noqa: E402
from regen.falsify.candidate import NO_EDIT  # noqa: E402
from regen.runfolder import RunFolder  # noqa: E402

pytestmark = pytest.mark.slow


def _a_finding_where_the_scripted_ego_verified(f, policy: str) -> None:
    assert f.scripted.verified and not f.scripted.collision and f.policy.status == "failed"
    tests = json.loads(Path(f.tests).read_text())  # written exactly as regen test writes it
    (case,) = tests["cases"]
    assert case["status"] == "failed" and case["adversarial"] and case["template"]["verified"]
    assert not case["template"]["collision"]
    assert (Path(f.folder) / RunFolder.MANIFEST).is_file() and Path(f.xosc).suffix == ".xosc"
    assert f.replay == f"regen test {f.folder} --policy {policy}"


def test_a_policy_that_fails_the_scenario_as_generated_gets_one_finding_with_no_edit(searched):
    """constant-speed hits the child without any edit: that is the scenario's one finding (its
    minimal edit set is empty), and none of its edits is tried though the budget allows more."""
    out, report = searched
    assert report.status == "done" and report.budget == 3 and report.tried == report.simulated == 1
    (baseline,) = report.candidates
    assert baseline.origin == "baseline" and baseline.edits == [] and baseline.words == [NO_EDIT]
    assert baseline.status == "failed" and baseline.minimal and baseline.chain == [baseline.cid]
    (f,) = report.findings
    assert f.cid == baseline.cid and f.scenario == CHILD and f.edit_list == [] and f.edits == [NO_EDIT]
    assert f.minimal and f.chain == [[NO_EDIT]] and f.failure.startswith("collision with child1")
    _a_finding_where_the_scripted_ego_verified(f, "constant-speed")
    (source,) = report.sources
    assert source["scenario"] == CHILD and source["baseline"] == "failed" and source["singles"] > 0
    assert "fails without any edit" in source["note"]
    saved = json.loads((out / "falsify.json").read_text())  # the candidates as written: no edit searched
    assert [(c["origin"], c["edits"], c["status"]) for c in saved["candidates"]] == [("baseline", [], "failed")]
    assert [x["edit_list"] for x in saved["findings"]] == [[]] and saved["failures"] == 1
    assert saved["parameter_search"] == "parameter search not run: --param-budget 0"


def test_a_policy_that_passes_the_baseline_gets_findings_where_the_scripted_ego_verified(searched_aeb):
    """aeb stops for the child as generated: its baseline is recorded as passed and the single
    edits are searched as before; the findings are edits."""
    out, report = searched_aeb
    assert report.status == "done" and report.simulated == 7 and report.budget == 7
    assert [c.words for c in report.candidates][:4] == [[NO_EDIT], [f"add cause '{OTHER_CAUSE}'"],
                                                        ["remove child1"], ["set child1.behavior = stationary"]]
    baseline = report.candidates[0]
    assert baseline.origin == "baseline" and baseline.edits == [] and baseline.status == "passed"
    assert baseline.scripted.verified and baseline.policy.status == "passed" and baseline.minimal is None
    assert all(c.origin == "single" and len(c.edits) == 1 for c in report.candidates[1:])
    (source,) = report.sources
    assert source["baseline"] == "passed" and "note" not in source
    assert report.findings, [c.reason for c in report.candidates]
    for f in report.findings:
        assert f.edit_list and NO_EDIT not in f.edits and f.cid != baseline.cid
        assert f.minimal and f.chain == [f.edits]
        _a_finding_where_the_scripted_ego_verified(f, "aeb")
    (fast,) = report.findings
    assert fast.edits == ["set child1.target_speed = fast"] and fast.scripted.causal == "caused"
    assert fast.failure.startswith("missed state: ")
    # a child that stands still: aeb does not stop, and neither does the reference driver, so the
    # missed stop is no failure of aeb's (the world no longer calls for it)
    stationary = next(c for c in report.candidates if c.words == ["set child1.behavior = stationary"])
    assert stationary.status == "invalid" and stationary.scripted.causal == "not_sufficient"
    assert "does not call for" in stationary.reason
    saved = json.loads((out / "falsify.json").read_text())
    assert saved["tried"] == report.tried and len(saved["findings"]) == len(report.findings)
    assert (saved["candidates"][0]["origin"], saved["candidates"][0]["status"]) == ("baseline", "passed")
    assert saved["parameter_search"] == "parameter search not run: --param-budget 0"


def test_a_candidate_the_scripted_ego_does_not_survive_is_invalid_never_a_finding(searched_aeb):
    _, report = searched_aeb
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

    real = suite.template_check

    def colliding(run):
        check = real(run)
        return TemplateCheck(verified=check.verified, status=check.status, collision=True,
                             message=f"{check.message}; the scripted ego collides: the ego hit child1")

    monkeypatch.setattr(suite, "template_check", colliding)
    report = run_falsify(driving_run, "constant-speed", budget=1, out=tmp_path / "fz", pictures=False,
                         param_budget=0)
    (rec,) = report.candidates
    assert rec.scripted.verified and rec.scripted.collision and rec.status == "invalid"
    assert "collides" in rec.reason and not report.findings and report.failures == 0


@pytest.mark.parametrize(("searched_by", "policy"), [("searched", "constant-speed"), ("searched_aeb", "aeb")])
def test_a_finding_replays_with_regen_test(searched_by, policy, request):
    """The finding with no edit (constant-speed) and one with an edit (aeb)."""
    from regen.harness.suite import run_tests

    _, report = request.getfixturevalue(searched_by)
    f = report.findings[0]
    again = run_tests(f.folder, policy)
    (case,) = again.cases
    assert case.status == "failed" and case.cause == f.policy.cause
    assert case.collision_with == f.policy.collision_with


@pytest.mark.parametrize(("searched_by", "budget"), [("searched", 3), ("searched_aeb", 7)])
def test_a_rerun_keeps_the_finished_candidates(searched_by, budget, request, monkeypatch):
    from regen.falsify import candidate

    out, report = request.getfixturevalue(searched_by)
    policy = report.policy

    def never(*args, **kwargs):
        raise AssertionError("a finished candidate was run again")

    monkeypatch.setattr(candidate, "run_candidate", never)
    monkeypatch.setattr("regen.falsify.search.run_candidate", never)
    again = run_falsify(report.run, policy, budget=budget, out=out, pictures=False, param_budget=0)
    assert again.kept == again.tried == report.tried and all(c.kept for c in again.candidates)
    assert [c.origin for c in again.candidates] == [c.origin for c in report.candidates]
    assert [f.cid for f in again.findings] == [f.cid for f in report.findings]
    assert [f.minimal for f in again.findings] == [f.minimal for f in report.findings]


def test_the_model_s_causes_are_added_and_marked(driving_run, tmp_path, monkeypatch):
    from regen.llm import LLM, registry
    from regen.llm.testing import QueuedProvider

    provider = QueuedProvider([{"causes": ["a police car blocks the lane ahead", "the ego's brakes fail",
                                           OTHER_CAUSE]}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    llm = LLM("queued:test", cache=str(tmp_path / "cache.sqlite"))
    # aeb passes the scenario as generated, so its edits are searched: the baseline and a single
    # spend half the budget, then the model is asked
    report = run_falsify(driving_run, "aeb", budget=4, out=tmp_path / "fz", llm=llm, pictures=False, param_budget=0)
    (request,) = provider.requests
    prompt = request[-1]["content"]
    assert "aeb" in prompt and "child1" in prompt and OTHER_CAUSE in prompt  # tried causes named
    (asked,) = report.model
    assert asked.causes == ["a police car blocks the lane ahead"]
    assert set(asked.rejected) == {"the ego's brakes fail", OTHER_CAUSE}
    assert [c.origin for c in report.candidates] == ["baseline", "single", "model", "single"]
    _, first, second, _ = report.candidates
    assert not first.by_model and first.words == [f"add cause '{OTHER_CAUSE}'"]
    assert second.by_model and second.words == ["add cause 'a police car blocks the lane ahead'"]
    assert report.settings["llm"].startswith("queued")


def test_without_the_parameter_module_the_stage_says_why(searched_aeb, monkeypatch):
    out, report = searched_aeb
    monkeypatch.setitem(sys.modules, "regen.falsify.params", None)  # import fails
    again = run_falsify(report.run, "aeb", budget=7, out=out, pictures=False, param_budget=4)
    assert again.parameter_search.startswith("parameter search not run: ")
    assert all(f.parameter_search is None for f in again.findings)


# --- the search's order, over fake candidates ------------------------------------------------------------


def _fake(fails, ungroundable=lambda words: False):
    """A run_candidate that simulates nothing: a candidate fails when ``fails(words)``, cannot be
    grounded when ``ungroundable(words)``, else passes."""

    def run_candidate(bench, source, edits, *, origin="single", by_model=False):
        from regen.falsify.space import candidate_id, canonical

        edits = canonical(edits)
        words = [e.describe() for e in edits] or [NO_EDIT]  # as run_candidate words the baseline
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
    assert sizes == [0] + [1] * singles + [2] * (len(sizes) - singles - 1) and singles == 17  # breadth-first
    assert report.candidates[0].origin == "baseline" and report.candidates[0].status == "passed"
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


def _queued_llm(tmp_path, monkeypatch, answers):
    from regen.llm import LLM, registry
    from regen.llm.testing import QueuedProvider

    provider = QueuedProvider(answers)
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    return provider, LLM("queued:test", cache=str(tmp_path / "cache.sqlite"))


def test_a_scenario_failing_as_generated_is_neither_searched_nor_sent_to_the_model(driving_run, tmp_path,
                                                                                   monkeypatch):
    """Every candidate would fail: the baseline does, so it is the one finding and no single,
    pair, shrink or model cause of the scenario is tried, though the budget allows them."""
    provider, llm = _queued_llm(tmp_path, monkeypatch, [{"causes": ["a police car blocks the lane ahead"]}])
    monkeypatch.setattr("regen.falsify.search.run_candidate", _fake(lambda w: True))
    report = run_falsify(driving_run, "constant-speed", budget=30, out=tmp_path / "fz", llm=llm, param_budget=0)
    assert not provider.requests and report.model == []
    (baseline,) = report.candidates
    assert baseline.origin == "baseline" and baseline.edits == [] and baseline.minimal
    (f,) = report.findings
    assert f.edit_list == [] and f.edits == [NO_EDIT] and f.minimal and f.chain == [[NO_EDIT]]
    assert report.tried == report.simulated == report.failures == 1


def test_no_model_call_once_the_baselines_spent_the_budget(driving_run, tmp_path, monkeypatch):
    provider, llm = _queued_llm(tmp_path, monkeypatch, [{"causes": ["a police car blocks the lane ahead"]}])
    monkeypatch.setattr("regen.falsify.search.run_candidate", _fake(lambda w: False))
    report = run_falsify(driving_run, "constant-speed", budget=1, out=tmp_path / "fz", llm=llm, param_budget=0)
    assert [c.origin for c in report.candidates] == ["baseline"] and report.candidates[0].status == "passed"
    assert not provider.requests and report.model == [] and not report.findings


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
