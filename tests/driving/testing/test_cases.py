"""A policy in the loop of a grounded scenario (real Scenic Newtonian simulator), the oracle,
tests.json / junit.xml and the ``regen test`` command."""

from __future__ import annotations

import json
import math
import textwrap
import time
import xml.etree.ElementTree as ET

import pytest
from driving_chains import FEASIBLE, verified_run  # noqa: E402

pytest.importorskip("scenic")

from regen.driving.testing.harness import DrivingHarness  # noqa: E402
from regen.driving.testing.loop import prepare, run_policy  # noqa: E402
from regen.driving.testing.policies import Action, constant_speed, load_policy  # noqa: E402
from regen.driving.verify.collisions import analyze  # noqa: E402
from regen.harness.junit import junit_xml, write_report  # noqa: E402
from regen.harness.oracle import judge  # noqa: E402
from regen.harness.suite import run_tests  # noqa: E402
from regen.runfolder import RunFolder  # noqa: E402

pytestmark = pytest.mark.slow

HARNESS = DrivingHarness()
CHILD = "01-child-crosses"  # stop_abruptly: a child runs across the road in front of the ego


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A run folder with one verified scenario."""
    yield from verified_run(tmp_path_factory, {CHILD: FEASIBLE["stop_abruptly"][0]})


@pytest.fixture(scope="module")
def prepared(run_dir):
    return prepare(RunFolder(run_dir).scenario(CHILD).scenario())


def _case(prepared, policy, **kw):
    episode = run_policy(prepared, policy, **kw)
    return episode, judge(HARNESS, prepared.scenario, episode, folder=CHILD)


def test_constant_speed_runs_over_the_crossing_child(prepared):
    episode, case = _case(prepared, constant_speed)
    assert episode.failure is None and episode.steps == prepared.steps
    ego = episode.trace.actors["ego"]
    assert min(ego.speed) > 9.5  # it never brakes
    assert case.status == "failed" and case.cause == "collision" and case.collision_with == "child1"
    assert "collision" in case.message and case.min_ttc == 0.0


def test_idm_yields_to_the_child_but_does_not_stop(prepared):
    episode, case = _case(prepared, load_policy("idm"))
    speed = episode.trace.actors["ego"].speed
    assert not analyze(episode.trace).collisions and min(speed) < 5.0
    # the oracle asks for the ego's states, not the template's manner: IDM brakes early and
    # gently (the template's braking(ego, min_decel=4.0) would fail it) and that counts as
    # braking; but the child is across before IDM gets there, so it never stops: the FSM oracle
    # fails it at 'stopped', the safety oracle passes it
    assert case.robot_stages[1].reached_at is not None
    assert case.cause == "state_not_reached" and "'stopped'" in case.message and min(speed) > 0.3
    safe = judge(HARNESS, prepared.scenario, episode, folder=CHILD, oracle="safety")
    assert safe.status == "passed" and "not required" in safe.message


def test_the_oracle_drops_the_template_manner_only(prepared):
    scenario = prepared.scenario

    def oracle_state(sc, name):
        return HARNESS.oracle_state(sc, sc.fsm.state("ego", name))

    ego_states = {s.name: s for s in scenario.fsm.states if s.actor == "ego"}
    assert ego_states["braking"].all_of[0].params["min_decel"] > 1.0  # the template brakes hard
    braking = oracle_state(scenario, "braking")
    assert [(c.name, c.params) for c in braking.all_of] == [("braking", {"min_decel": 0.5})]
    assert oracle_state(scenario, "stopped") == ego_states["stopped"]  # states are kept as they are


def test_aeb_brakes_hard_for_the_child_and_passes(prepared):
    _, case = _case(prepared, load_policy("aeb"))
    assert case.status == "passed", case.message


def test_the_ego_steers_along_its_route(prepared):
    episode, _ = _case(prepared, constant_speed)
    ego = episode.trace.actors["ego"]
    assert max(abs(y - ego.y[0]) for y in ego.y) < 0.2  # stays in its lane [m]


def _boom(obs):
    if obs.t > 1.0:
        raise ZeroDivisionError("policy bug")
    return Action(0.0, 0.0)


def test_a_crashing_policy_is_a_failed_test_with_the_reason(prepared):
    episode, case = _case(prepared, _boom)
    assert episode.failure_kind == "exception" and episode.failure_time == pytest.approx(1.1)
    assert case.status == "failed" and case.cause == "policy_exception"
    assert "ZeroDivisionError: policy bug" in case.message


def test_a_nan_policy_is_a_failed_test_with_the_reason(prepared):
    _, case = _case(prepared, lambda obs: Action(float("nan"), 0.0))
    assert case.cause == "policy_invalid_action" and "not finite" in case.message


def test_a_slow_policy_is_a_failed_test_with_the_reason(prepared):
    def slow(obs):
        time.sleep(0.5 if obs.t >= 0.5 else 0.0)
        return Action(0.0, 0.0)

    t0 = time.perf_counter()
    _, case = _case(prepared, slow, step_timeout=0.05)
    assert time.perf_counter() - t0 < 3.0
    assert case.cause == "policy_timeout" and "0.05 s" in case.message


def test_observation_carries_the_world(prepared):
    seen = []

    def spy(obs):
        seen.append(obs)
        return constant_speed(obs)

    run_policy(prepared, spy, steps=20)
    assert len(seen) == 20 and seen[0].t == 0.0 and seen[1].t == pytest.approx(0.1)
    first = seen[0]
    assert first.ego.speed == pytest.approx(10.0) and first.ego.cruise_speed == pytest.approx(10.0)
    assert 5 <= len(first.ego.route_ahead) <= 13  # waypoints 5 m apart, 60 m ahead
    (child,) = first.actors
    assert child.name == "child1" and child.category == "pedestrian" and math.isfinite(child.vx)


def test_reports_and_junit_parse(run_dir, tmp_path):
    report = run_tests(run_dir, "constant-speed")
    files = write_report(report, tmp_path / "out")
    data = json.loads(files["tests"].read_text())
    assert data["summary"] == {"tests": 1, "passed": 0, "failed": 1, "skipped": 0, "errors": 0, "collisions": 1}
    root = ET.parse(files["junit"]).getroot()
    (case,) = root.iter("testcase")
    assert case.get("name") == f"{CHILD}[variant 0]"
    assert "collision" in case.find("failure").get("message")
    assert report.collision_line() == "collision rate: 1/1"
    assert junit_xml(report).startswith("<?xml")


def test_cli_with_a_users_policy_file(run_dir, tmp_path):
    from typer.testing import CliRunner

    from regen.harness.cli import make_app

    f = tmp_path / "outside" / "brake_early.py"
    f.parent.mkdir()
    f.write_text(textwrap.dedent("""
        from regen.driving.testing.policies import Action, route_curvature

        def policy(obs):
            # brake to a stop whenever a pedestrian is within 30 m
            near = any(a.category == "pedestrian" and abs(a.x - obs.ego.x) < 30 for a in obs.actors)
            return Action(-6.0 if near else 0.0, route_curvature(obs.ego))
    """))
    out = tmp_path / "out"
    res = CliRunner().invoke(make_app(), [str(run_dir), "--policy", f"{f}:policy", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert f"PASS  {CHILD}" in res.output and "collision rate: 0/1" in res.output
    assert (out / "junit.xml").is_file() and (out / "tests.json").is_file()
    # written outside RUN/tests: the report cannot show them, and the terminal says so
    assert "only; these are not in it)" in " ".join(res.output.split())

    res = CliRunner().invoke(make_app(), [str(run_dir), "--policy", "constant-speed", "--out", str(out)])
    assert res.exit_code == 1 and f"FAIL  {CHILD}  collision" in res.output
    res = CliRunner().invoke(make_app(), [str(run_dir), "--policy", "constant-speed"])  # into RUN/tests
    assert "report: " in res.output and "not in it" not in res.output
    res = CliRunner().invoke(make_app(), [str(run_dir), "--policy", "no-such-policy"])
    assert res.exit_code == 2 and "unknown policy" in res.output


@pytest.mark.parametrize("hostile", ["a\x01b", "end\ufffe", "lone \ud800 surrogate", "bell\x07 and \x1b[31mred"])
def test_junit_is_well_formed_whatever_a_policy_says(run_dir, tmp_path, hostile):
    report = run_tests(run_dir, "constant-speed")
    (case,) = report.cases
    report = report.model_copy(update={"cases": [case.model_copy(update={"message": f"policy said {hostile}"})]})
    files = write_report(report, tmp_path / "out")
    root = ET.parse(files["junit"]).getroot()  # well-formed XML 1.0, written without an error
    failure = next(root.iter("failure"))
    assert failure.get("message").startswith("policy said ") and "\ufffd" in failure.get("message")
    assert json.loads(files["tests"].read_text())["summary"]["failed"] == 1


def test_no_test_ran_is_exit_1_not_green(run_dir, tmp_path):
    import shutil

    from typer.testing import CliRunner

    from regen.harness.cli import make_app

    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    for v in run.glob("scenarios/*/verdict.json"):  # nothing verified: every case is skipped
        data = json.loads(v.read_text())
        data.update(feasible=False, status="cause_not_shown")
        v.write_text(json.dumps(data))
    res = CliRunner().invoke(make_app(), [str(run), "--policy", "constant-speed", "--out", str(tmp_path / "o")])
    assert res.exit_code == 1, res.output
    assert "no test ran" in " ".join(res.output.split())
