"""``regen test`` on a manipulation run (real PyBullet): the policy runs in its own process in
this domain too; a policy that exits or hangs fails its own case, and a run with nothing to
test is not green."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from regen.harness.cli import make_app
from regen.runfolder import RunFolder, ScenarioFolder

pytestmark = pytest.mark.slow

NAME = "01-pet-in-reach"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, pet_in_reach, harness):
    """A run folder holding the door scenario, verified by the scripted robot."""
    run = tmp_path_factory.mktemp("manip-run")
    folder = ScenarioFolder(run / RunFolder.SCENARIOS / NAME)
    folder.path.mkdir(parents=True)
    template = harness.check_template(pet_in_reach)
    assert template.verdict is not None and template.verdict.feasible, template.error
    folder.write_scenario(template.judged or pet_in_reach, {})
    folder.write_trace(template.trace)
    folder.write_verdict(template.verdict)
    return run


def _test(run: Path, *args: str):
    return CliRunner().invoke(make_app(), [str(run), *args], catch_exceptions=False)


def _cases(out: Path) -> list[dict]:
    return json.loads((out / "tests.json").read_text())["cases"]


def test_the_scripted_policy_passes_through_its_process(run_dir, tmp_path):
    res = _test(run_dir, "--policy", "scripted", "--out", str(tmp_path / "out"))
    assert res.exit_code == 0, res.output
    assert [c["status"] for c in _cases(tmp_path / "out")] == ["passed"]


@pytest.mark.parametrize(("body", "cause"), [
    ("import os\ndef policy(o):\n    os._exit(0)\n", "policy_crash"),
    ("import time\ndef policy(o):\n    while True:\n        try:\n            time.sleep(5)\n"
     "        except BaseException:\n            pass\n", "policy_timeout"),
    ("def policy(o):\n    return (1e400 * 0, 0.0, 0.0)\n", "policy_invalid_action"),
], ids=["os._exit", "hang", "nan"])
def test_a_faulty_policy_fails_its_case_and_the_command_ends(run_dir, tmp_path, body, cause):
    f = tmp_path / "bad.py"
    f.write_text(body)
    res = _test(run_dir, "--policy", str(f), "--out", str(tmp_path / "out"), "--step-timeout", "0.3")
    assert res.exit_code == 1, res.output
    assert [c["cause"] for c in _cases(tmp_path / "out")] == [cause]


def test_a_run_with_nothing_verified_is_exit_1(run_dir, tmp_path):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    verdict = run / RunFolder.SCENARIOS / NAME / "verdict.json"
    data = json.loads(verdict.read_text())
    data.update(status="cause_not_shown", feasible=False)
    verdict.write_text(json.dumps(data))
    res = _test(run, "--policy", "scripted", "--out", str(tmp_path / "out"))
    assert res.exit_code == 1 and "no test ran" in res.output
    assert [c["status"] for c in _cases(tmp_path / "out")] == ["skipped"]
