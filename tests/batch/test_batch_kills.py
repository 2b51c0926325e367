"""A batch survives kills: `kill -9` of one simulation worker costs only a retry of its
scenario, `kill -9` of the batch loses nothing finished and the same command resumes. A real
`regen batch` subprocess on the real driving simulator with a scripted model
(tests/support/scripted_cli.py plugs it in as `llm: scripted`)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

SUPPORT = Path(__file__).resolve().parents[1] / "support"
STOP = "the ego-vehicle stops abruptly while driving forward"
SPEC = f"""behaviors:
  - text: {STOP}
    domain: driving
    scenarios: 2
    llm: scripted
    pictures: false
  - text: {STOP}
    domain: driving
    ego: stop_in_intersection
    scenarios: 1
    llm: scripted
    pictures: false
"""


def _start(tmp_path: Path) -> subprocess.Popen:
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC)
    cmd = [sys.executable, str(SUPPORT / "scripted_cli.py"), "batch", str(spec), "--out", str(tmp_path / "out"),
           "--workers", "2", "--log", "jsonl"]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _events(tmp_path: Path) -> list[dict]:
    out = []
    for f in (tmp_path / "out").glob("*/events.jsonl"):
        out += [json.loads(line) for line in f.read_text().splitlines() if line.strip()]
    return out


def _wait(tmp_path: Path, proc: subprocess.Popen, what, timeout: float = 300.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise AssertionError(f"the batch ended first: {proc.communicate()}")
        if what(_events(tmp_path)):
            return
        time.sleep(0.2)
    proc.kill()
    raise AssertionError("timed out")


def _verdicts(tmp_path: Path) -> dict[str, str]:
    return {str(p.relative_to(tmp_path / "out")): p.read_text()
            for p in sorted((tmp_path / "out").glob("*/scenarios/*/verdict.json"))}


def _finish(tmp_path: Path) -> subprocess.CompletedProcess:
    proc = _start(tmp_path)
    out, err = proc.communicate(timeout=600)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def _cpu_ticks(pid: int) -> int | None:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return int(fields[11]) + int(fields[12])  # utime + stime


def _busy_worker(proc: subprocess.Popen, timeout: float = 120.0) -> int | None:
    """A simulation worker while it runs a scenario (it uses the CPU; an idle one waits on its
    pipe). The workers are forked by the pool's zygote, the batch's child (regen.pipeline.zygote),
    once it has loaded the simulators; a warm worker's scenario takes a fraction of a second, so
    they are sampled every 50 ms."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout and proc.poll() is None:
        zygotes = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout.split()
        workers = [int(w) for z in zygotes
                   for w in subprocess.run(["pgrep", "-P", z], capture_output=True, text=True).stdout.split()]
        before = {w: _cpu_ticks(w) for w in workers}
        time.sleep(0.05)
        for w in workers:
            after = _cpu_ticks(w)
            if before[w] is not None and after is not None and after - before[w] >= 1:
                return w
    return None


def test_kill_9_of_a_worker_retries_its_scenario_and_of_the_batch_loses_nothing(tmp_path) -> None:
    pytest.importorskip("scenic")
    proc = _start(tmp_path)
    _wait(tmp_path, proc, lambda evs: any(e.get("stage") == "simulate" for e in evs))
    busy = _busy_worker(proc)
    assert busy, "no simulation worker was seen running a scenario"
    os.kill(busy, signal.SIGKILL)  # a simulator's crash, the OOM killer
    _wait(tmp_path, proc, lambda evs: sum(e.get("event") == "scenario_done" for e in evs) >= 1)
    proc.kill()  # then the whole batch
    _, err = proc.communicate(timeout=30)
    assert "the worker process running it died (exit code -9); running that scenario once more" in err
    kept = _verdicts(tmp_path)
    assert kept, "nothing was finished before the kill"
    killed_leg = json.loads((tmp_path / "out" / "batch.json").read_text())
    # the killed invocation's wall time up to its last finished scenario is kept, per behavior too
    assert killed_leg["wall_seconds"] > 1.0 and sum(b["wall_seconds"] for b in killed_leg["behaviors"]) > 1.0
    done = _finish(tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    record = json.loads((tmp_path / "out" / "batch.json").read_text())
    assert record["status"] == "done" and [b["status"] for b in record["behaviors"]] == ["done", "done"]
    assert record["wall_seconds"] > killed_leg["wall_seconds"]  # both invocations counted
    assert all(not b["failed_scenarios"] for b in record["behaviors"])
    after = _verdicts(tmp_path)
    assert len(after) == 3 and {k: after[k] for k in kept} == kept  # finished work kept, not redone
    assert (tmp_path / "out" / "report.html").is_file()
