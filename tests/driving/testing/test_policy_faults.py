"""Fault injection for ``regen test``: hostile and broken policies, kills, interrupts, full disks,
broken scenario files and concurrent commands, on a real run folder (two verified driving
scenarios, the Scenic Newtonian simulator). Each test is a probe of issue 20 that failed on
the main branch before the policy ran in its own process and cases were written one by one.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from driving_chains import FEASIBLE, verified_run  # noqa: E402

pytest.importorskip("scenic")

from typer.testing import CliRunner  # noqa: E402

from regen.harness.cli import default_out, make_app  # noqa: E402

pytestmark = pytest.mark.slow

CHILD = "01-child-crosses"  # stop_abruptly: full throttle runs over the child
SLOW = "02-slow-truck"  # slow_down behind a slow truck
DRIVE = "from regen.driving.testing.policies import Action, route_curvature\n"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    yield from verified_run(tmp_path_factory, {CHILD: FEASIBLE["stop_abruptly"][0],
                                               SLOW: FEASIBLE["slow_down"][0]})


def _policy(tmp_path: Path, body: str, name: str = "policy.py") -> Path:
    f = tmp_path / name
    f.write_text(textwrap.dedent(body))
    return f


def _test(run: Path, *args: str):
    return CliRunner().invoke(make_app(), [str(run), *args], catch_exceptions=False)


def _cases(out: Path) -> list[dict]:
    return json.loads((out / "tests.json").read_text())["cases"]


def _junit(out: Path) -> ET.Element:
    return ET.parse(out / "junit.xml").getroot()  # well-formed, or this raises


def _cli(*args: str, **kw) -> subprocess.Popen:
    """``regen test`` as a user runs it: its own process (kills and signals reach only it), with
    Ctrl-C's default meaning even when the suite itself was started in the background (a shell
    without job control starts background commands with SIGINT ignored, and children inherit it)."""
    return subprocess.Popen([sys.executable, "-m", "regen.cli", "test", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL), **kw)


# --- the policy cannot crash, fake or hang the harness ---------------------------------------


@pytest.mark.parametrize(("body", "cause", "words"), [
    ("import os\ndef policy(o):\n    os._exit(0)\n", "policy_crash", "ended (exit code 0)"),
    ("import sys\ndef policy(o):\n    sys.exit(3)\n", "policy_exception", "SystemExit: 3"),
    ("def policy(o):\n    raise KeyboardInterrupt\n", "policy_exception", "KeyboardInterrupt"),
    ("import os, signal\ndef policy(o):\n    os.kill(os.getpid(), signal.SIGKILL)\n", "policy_crash", "signal 9"),
    ("def policy(o):\n    return (10**400, 0.0)\n", "policy_invalid_action", "not numeric"),
], ids=["os._exit", "sys.exit", "KeyboardInterrupt", "SIGKILL", "10**400"])
def test_a_policy_that_exits_or_dies_fails_its_own_cases_only(run_dir, tmp_path, body, cause, words):
    out = tmp_path / "out"
    res = _test(run_dir, "--policy", str(_policy(tmp_path, body)), "--out", str(out))
    assert res.exit_code == 1, res.output  # the harness's own code: tests failed
    cases = _cases(out)
    assert [c["scenario"] for c in cases] == [CHILD, SLOW]
    assert all(c["cause"] == cause and words in c["message"] for c in cases), cases
    assert len(list(_junit(out).iter("failure"))) == 2


def test_replacing_the_oracle_in_the_policys_module_changes_nothing(run_dir, tmp_path):
    f = _policy(tmp_path, """
        import regen.harness.oracle as oracle, regen.harness.suite as suite
        from regen.driving.testing.policies import route_curvature
        from regen.harness.cases import CaseResult

        def fake(harness, scenario, episode, *, folder, variant=0, **kw):
            return CaseResult(scenario=folder, variant=variant, status="passed")

        oracle.judge = suite.judge = fake

        def policy(o):
            return (5.6, route_curvature(o.ego))  # full throttle
    """)
    out = tmp_path / "out"
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert res.exit_code == 1, res.output
    assert [c["status"] for c in _cases(out)] == ["failed", "failed"]  # not "2/2 passed"


HANGS = {
    "catches every exception around a sleep": """
        import time
        def policy(o):
            while True:
                try:
                    time.sleep(5)
                except BaseException:
                    pass
    """,
    "returns an object whose __float__ is slow": """
        import time
        class Slow:
            def __float__(self):
                time.sleep(30)
                return 0.0
        def policy(o):
            return (Slow(), 0.0)
    """,
    "disarms the interval timer": """
        import signal, time
        def policy(o):
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, signal.SIG_IGN)
            time.sleep(30)
            return (0.0, 0.0)
    """,
    "hides the timeout under a bare except": """
        import time
        def policy(o):
            try:
                time.sleep(30)
            except:  # noqa: E722
                pass
            return (0.0, 0.0)
    """,
}


@pytest.mark.parametrize("how", HANGS)
def test_a_policy_that_hangs_is_stopped_at_the_step_timeout(run_dir, tmp_path, how):
    out = tmp_path / "out"
    t0 = time.monotonic()
    res = _test(run_dir, "--policy", str(_policy(tmp_path, HANGS[how])), "--out", str(out), "--step-timeout", "0.3")
    wall = time.monotonic() - t0
    assert res.exit_code == 1, res.output
    assert [c["cause"] for c in _cases(out)] == ["policy_timeout", "policy_timeout"]
    assert "0.3 s" in _cases(out)[0]["message"]
    assert wall < 25, wall  # two cases, each stopped at its first step (plus starting processes)


def test_a_policy_that_leaves_a_thread_running_lets_the_command_end(run_dir, tmp_path):
    f = _policy(tmp_path, DRIVE + textwrap.dedent("""
        import threading, time

        def spin():
            while True:
                time.sleep(0.1)

        threading.Thread(target=spin).start()  # not a daemon: it would keep a process alive

        def policy(o):
            return Action(0.0, route_curvature(o.ego))
    """))
    proc = _cli(str(run_dir), "--policy", str(f), "--out", str(tmp_path / "out"))
    _, err = proc.communicate(timeout=120)  # raises TimeoutExpired if the command never ends
    assert proc.returncode == 1, err
    assert [c["cause"] for c in _cases(tmp_path / "out")] == ["collision", "collision"]


def test_a_policy_that_changes_directory_moves_nothing(run_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    f = _policy(tmp_path, DRIVE + f"import os\nos.chdir({str(elsewhere)!r})\n"
                "def policy(o):\n    os.chdir('/')\n    return Action(-6.0 if o.t > 1 else 0.0, route_curvature(o.ego))\n")
    res = _test(Path(os.path.relpath(run_dir)), "--policy", "policy.py", "--out", "rel-out")
    assert res.exit_code in (0, 1), res.output
    assert [c["scenario"] for c in _cases(tmp_path / "rel-out")] == [CHILD, SLOW]
    assert not list(elsewhere.iterdir()) and Path.cwd() == tmp_path
    assert f.is_file()


def test_the_policy_process_gets_no_language_model_key(run_dir, tmp_path, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test-not-for-policies")
    monkeypatch.setenv("MY_POLICY_SETTING", "kept")
    f = _policy(tmp_path, DRIVE + textwrap.dedent("""
        import os
        assert "OPENAI_API_KEY" not in os.environ, "the key reached the policy"
        assert os.environ["MY_POLICY_SETTING"] == "kept"

        def policy(o):
            return Action(0.0, route_curvature(o.ego))
    """))
    res = _test(run_dir, "--policy", str(f), "--out", str(tmp_path / "out"))
    assert res.exit_code == 1 and "collision" in res.output, res.output  # it loaded and drove


def test_a_class_whose_constructor_raises_is_one_line(run_dir, tmp_path):
    f = _policy(tmp_path, "class Policy:\n    def __init__(self):\n        raise RuntimeError('no weights')\n")
    res = _test(run_dir, "--policy", f"{f}:Policy", "--out", str(tmp_path / "out"))
    assert res.exit_code == 2
    assert "RuntimeError: no weights" in res.output and "Traceback" not in res.output


def test_hostile_messages_leave_junit_well_formed(run_dir, tmp_path):
    f = _policy(tmp_path, "def policy(o):\n    raise ValueError('a\\x01b end\\ufffe lone \\ud800 x\\x1b[31m')\n")
    out = tmp_path / "out"
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert res.exit_code == 1
    failure = next(_junit(out).iter("failure"))
    assert "\ufffd" in failure.get("message") and "ValueError" in failure.get("message")


# --- results are kept as they finish, a rerun resumes ---------------------------------------


def _counting(tmp_path: Path, extra: str = "") -> Path:
    """A braking policy that appends a line to resets.txt at every episode start."""
    return _policy(tmp_path, DRIVE + textwrap.dedent(f"""
        import os
        LOG = {str(tmp_path / 'resets.txt')!r}
        MARK = {str(tmp_path / 'mark')!r}

        class Policy:
            def reset(self):
                with open(LOG, "a") as fh:
                    fh.write("reset\\n")
                n = len(open(LOG).read().split())
                {extra or 'pass'}

            def __call__(self, o):
                return Action(-6.0 if o.t > 1 else 0.0, route_curvature(o.ego))

        policy = Policy()
    """))


def test_kill_9_keeps_the_finished_cases_and_a_rerun_resumes(run_dir, tmp_path):
    # the policy kills regen test at the start of the second case, once
    f = _counting(tmp_path, "if n == 2 and not os.path.exists(MARK):\n"
                            "                    open(MARK, 'w').close()\n"
                            "                    os.kill(os.getppid(), 9)")
    out = tmp_path / "out"
    proc = _cli(str(run_dir), "--policy", str(f), "--out", str(out))
    proc.communicate(timeout=120)
    assert proc.returncode == -signal.SIGKILL
    assert [c["scenario"] for c in _cases(out)] == [CHILD]  # the first case survived the kill
    assert (out / "cases" / f"{CHILD}-v0.json").is_file()
    _junit(out)
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert res.exit_code in (0, 1), res.output
    assert [c["scenario"] for c in _cases(out)] == [CHILD, SLOW]  # nothing twice
    assert (tmp_path / "resets.txt").read_text().split() == ["reset"] * 3  # the first case ran once
    assert "resuming" in res.output


def test_ctrl_c_ends_with_130_and_keeps_the_cases_so_far(run_dir, tmp_path):
    f = _counting(tmp_path, "if n == 1:\n                    open(MARK, 'w').close()")
    out = tmp_path / "out"
    proc = _cli(str(run_dir), "--policy", str(f), "--out", str(out), "--variants", "3")
    deadline = time.monotonic() + 300  # a loaded machine takes long to start the first case
    while not (tmp_path / "mark").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    kept = _cases(out)
    assert 1 <= len(kept) < 6 and all(c["status"] in ("passed", "failed", "skipped") for c in kept)
    assert len(list((out / "cases").glob("*.json"))) == len(kept)


def test_a_changed_policy_file_starts_over_with_a_message(run_dir, tmp_path):
    f = _counting(tmp_path)
    out = tmp_path / "out"
    assert _test(run_dir, "--policy", str(f), "--out", str(out)).exit_code in (0, 1)
    f.write_text(f.read_text() + "\n# edited\n")
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert "the policy file changed" in res.output and "starting over" in res.output
    assert (tmp_path / "resets.txt").read_text().split() == ["reset"] * 4


def test_out_that_is_a_file_is_refused_before_anything_runs(run_dir, tmp_path):
    f = _counting(tmp_path)
    (tmp_path / "taken").write_text("mine")
    res = _test(run_dir, "--policy", str(f), "--out", str(tmp_path / "taken"))
    assert res.exit_code == 2 and "is a file" in res.output
    assert not (tmp_path / "resets.txt").exists() and (tmp_path / "taken").read_text() == "mine"
    res = _test(run_dir, "--policy", str(f), "--out", "")
    assert res.exit_code == 2 and "--out is empty" in res.output


@pytest.mark.parametrize("errno_name", ["ENOSPC", "EROFS"])
def test_a_full_or_read_only_disk_is_one_line_and_a_rerun_resumes(run_dir, tmp_path, monkeypatch, errno_name):
    import errno

    import regen.core.io as io

    real, out = io.atomic_write_bytes, tmp_path / "out"
    refuse = {"on": False}

    def write(path, data):
        if refuse["on"] and f"{SLOW}-v0" in str(path):
            code = getattr(errno, errno_name)
            raise OSError(code, os.strerror(code), str(path))
        return real(path, data)

    monkeypatch.setattr(io, "atomic_write_bytes", write)
    refuse["on"] = True
    f = _counting(tmp_path)
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert res.exit_code == 2, res.output
    assert "cannot write" in res.output and "Traceback" not in res.output and "resume" in res.output
    assert [c["scenario"] for c in _cases(out)] == [CHILD]
    refuse["on"] = False
    res = _test(run_dir, "--policy", str(f), "--out", str(out))
    assert [c["scenario"] for c in _cases(out)] == [CHILD, SLOW]


# --- every verified scenario is in the results -------------------------------------------------


def _copy_run(run_dir: Path, tmp_path: Path) -> Path:
    import shutil

    run = tmp_path / "run"
    shutil.copytree(run_dir, run, ignore=shutil.ignore_patterns("tests", ".lock"))
    return run


@pytest.mark.parametrize("damage", ["unreadable scenario.json", "bad world.seed"])
def test_a_scenario_that_cannot_run_is_an_error_case_not_dropped(run_dir, tmp_path, damage):
    run = _copy_run(run_dir, tmp_path)
    path = run / "scenarios" / SLOW / "scenario.json"
    if damage == "unreadable scenario.json":
        path.write_text("{ not json")
    else:
        data = json.loads(path.read_text())
        data["scenario"]["world"]["seed"] = "banana"
        path.write_text(json.dumps(data))
    out = tmp_path / "out"
    res = _test(run, "--policy", "aeb", "--out", str(out))
    assert res.exit_code == 1, res.output
    cases = {c["scenario"]: c for c in _cases(out)}
    assert set(cases) == {CHILD, SLOW} and cases[SLOW]["cause"] == "error"
    assert "ERROR" in res.output and "could not run" in res.output
    errors = list(_junit(out).iter("error"))
    assert len(errors) == 1 and _junit(out).get("errors") == "1"


# --- locks, folders, pictures --------------------------------------------------------------


def test_a_run_that_regen_generate_holds_is_refused(run_dir, tmp_path):
    from regen.runfolder import RunFolder

    run = _copy_run(run_dir, tmp_path)
    held = RunFolder(run)
    held.lock()  # as regen generate holds it while it writes
    try:
        res = _test(run, "--policy", "aeb", "--out", str(tmp_path / "out"))
        assert res.exit_code == 2 and "regen generate" in res.output and "still writing" in res.output
    finally:
        held.unlock()
    assert _test(run, "--policy", "aeb", "--out", str(tmp_path / "out")).exit_code in (0, 1)  # it ran


def test_two_tests_on_one_out_folder_do_not_mix(run_dir, tmp_path):
    from regen.harness.results import ResultsFolder

    out = tmp_path / "out"
    other = ResultsFolder(out)
    other.check()
    other.lock()  # another regen test is writing there
    try:
        res = _test(run_dir, "--policy", "aeb", "--out", str(out))
        assert res.exit_code == 2 and "another regen test" in res.output
        assert not (out / "tests.json").exists()
    finally:
        other.close()


def test_a_case_that_now_passes_loses_its_old_failure_picture(run_dir, tmp_path):
    run = _copy_run(run_dir, tmp_path)
    f = _policy(tmp_path, DRIVE + textwrap.dedent("""
        import os

        def policy(obs):  # with BRAKE=1: stop whenever a pedestrian is within 30 m
            near = any(a.category == "pedestrian" and abs(a.x - obs.ego.x) < 30 for a in obs.actors)
            brake = os.environ.get("BRAKE") == "1" and near
            return Action(-6.0 if brake else 0.0, route_curvature(obs.ego))
    """))
    out = tmp_path / "out"
    assert _test(run, "--policy", str(f), "--out", str(out)).exit_code == 1
    assert (out / f"{CHILD}-v0" / "failure.gif").is_file()
    # the scenario is generated again (its files change), and this time the policy brakes
    verdict = run / "scenarios" / CHILD / "verdict.json"
    verdict.write_text(verdict.read_text() + "\n")
    os.environ["BRAKE"] = "1"
    try:
        res = _test(run, "--policy", str(f), "--out", str(out))
    finally:
        del os.environ["BRAKE"]
    case = next(c for c in _cases(out) if c["scenario"] == CHILD)
    assert case["status"] == "passed", res.output
    assert not (out / f"{CHILD}-v0").exists()  # no stale picture beside "passed"


def test_two_policy_files_with_one_name_get_two_folders(tmp_path):
    a, b = tmp_path / "a" / "policy.py", tmp_path / "b" / "policy.py"
    assert default_out(tmp_path, f"{a}:policy") != default_out(tmp_path, f"{b}:policy")
    assert default_out(tmp_path, str(a)) != default_out(tmp_path, str(b))
    assert default_out(tmp_path, "idm").name == "idm"
