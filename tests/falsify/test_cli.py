"""``regen falsify`` on the command line: refusals with a clear message and exit code 2, a run
end to end with its table, falsify.json, the candidates' lines and the run's report."""

from __future__ import annotations

import json
import re

import pytest
from typer.testing import CliRunner

from regen.cli import app

runner = CliRunner()


def _falsify(*args: str):
    return runner.invoke(app, ["falsify", *args], env={"COLUMNS": "200"})


def test_a_folder_that_is_not_a_run_is_refused(tmp_path):
    res = _falsify(str(tmp_path), "--policy", "constant-speed")
    assert res.exit_code == 2
    assert "is not a run folder with scenarios" in res.output and "regen generate" in res.output
    assert not (tmp_path / "falsify").exists()


def test_a_budget_below_one_is_refused(tmp_path):
    res = _falsify(str(tmp_path), "--policy", "constant-speed", "--budget", "0")
    assert res.exit_code == 2 and "--budget" in res.output and "greater than or equal to 1" in res.output


def test_the_library_refuses_a_budget_below_one_too(tmp_path):
    from regen.errors import ConfigError
    from regen.falsify import run_falsify

    with pytest.raises(ConfigError, match="--budget must be at least 1"):
        run_falsify(tmp_path, "constant-speed", budget=0)


def test_an_unknown_policy_is_refused_before_anything_is_written(driving_run):
    res = _falsify(str(driving_run), "--policy", "no-such-policy", "--budget", "1")
    assert res.exit_code == 2 and "no-such-policy" in res.output
    assert not (driving_run / "falsify" / "no-such-policy").exists()


@pytest.mark.slow
def test_a_search_prints_a_line_per_candidate_a_table_and_updates_the_report(driving_run):
    res = _falsify(str(driving_run), "--policy", "aeb", "--budget", "3", "--no-pictures", "--param-budget", "0")
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    # the scenario as generated first (aeb stops for the child), then its single edits
    assert re.match(r"PASS  \[1/3\] 01-child-crosses: no edit \(the scenario as generated\)  min TTC ", lines[0]), \
        lines[0]
    assert re.match(r"(PASS|FAIL|INVALID)  \[2/3\] 01-child-crosses: add cause 'a road worker", lines[1]), lines[1]
    assert lines[2].startswith("INVALID  [3/3] 01-child-crosses: remove child1  the scripted ego does not verify")
    assert "3/3 candidates simulated" in res.output and "1 invalid" in res.output
    out = driving_run / "falsify" / "aeb"
    saved = json.loads((out / "falsify.json").read_text())
    assert saved["policy"] == "aeb" and saved["status"] == "done" and saved["tried"] == 3
    assert saved["sources"][0]["baseline"] == "passed"
    assert f"report: {driving_run / 'report.html'}" in res.output
    html = (driving_run / "report.html").read_text()
    assert 'id="falsify"' in html and "falsify/aeb/falsify.json" in html


def test_the_run_keeps_its_falsify_folder_over_fresh(tmp_path):
    from regen.core.behavior import Behavior
    from regen.core.io import write_json
    from regen.runfolder import RunFolder, RunManifest, RunSettings, read_falsify
    from regen.runfolder.fresh import fresh_plan

    rf = RunFolder(tmp_path / "run")
    rf.path.mkdir()
    rf.write_manifest(RunManifest(behavior=Behavior(text="the ego-vehicle stops", domain="driving"),
                                  settings=RunSettings(llm="none")))
    write_json(rf.path / RunFolder.FALSIFY / "idm" / RunFolder.FALSIFY_JSON, {"policy": "idm"})
    plan = fresh_plan(rf)  # no error: falsify/ is the run's own, and kept
    assert not [p for p in plan.files + plan.folders if RunFolder.FALSIFY in p.parts]
    assert read_falsify(rf.path)["idm"].value == {"policy": "idm"}


@pytest.mark.slow
def test_llm_proposes_a_cause_cached_beside_falsify_json(driving_run, tmp_path, monkeypatch):
    from regen.llm import registry
    from regen.llm.testing import QueuedProvider

    provider = QueuedProvider([{"causes": ["a police car blocks the lane ahead"]}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    out = tmp_path / "fz"
    # aeb passes the scenario as generated (the first candidate, half the budget): then the model
    res = _falsify(str(driving_run), "--policy", "aeb", "--budget", "2", "--llm", "queued:test",
                   "--no-pictures", "--param-budget", "0", "--out", str(out))
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert lines[0].startswith("PASS  [1/2] 01-child-crosses: no edit (the scenario as generated)")
    assert "add cause 'a police car blocks the lane ahead' (model)" in lines[1]
    assert (out / "llm-cache.sqlite").is_file() and len(provider.requests) == 1
    saved = json.loads((out / "falsify.json").read_text())
    assert saved["model"][0]["causes"] == ["a police car blocks the lane ahead"]
    assert "not this one" in res.output  # the run's report shows RUN/falsify only
