"""`regen batch --ray ADDRESS` on a real Ray cluster: a head and a worker node started on
loopback by the test (one CPU each, no dashboard), a two-behavior batch with the offline model's
recorded answers (no model is loaded), and run folders equal to those of the process pool,
timings aside. The cluster is stopped by the test."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from regen.batch import run_batch
from regen.llm.cache import CallCache

pytestmark = pytest.mark.slow

CASSETTES = Path(__file__).resolve().parents[1] / "data" / "cassettes"
SPEC = """behaviors:
  - text: the ego-vehicle stops abruptly while driving forward
    domain: driving
    scenarios: 1
    pictures: false
  - text: the robot opens the door
    domain: manipulation
    scenarios: 2
    depth: 1
    causes: 3
    pictures: false
"""
CACHES = {"01-the-ego-vehicle-stops-abruptly-while-dri": "generate_driving.json",
          "02-the-robot-opens-the-door": "generate_manipulation_door.json"}
#: files that hold wall times (or the events with them): compared without those
TIMED = {"timings.json", "events.jsonl", "run.json", "summary.json", "report.html", "batch.json"}


def _ray_bin() -> str:
    if os.environ.get("CI"):
        import ray  # noqa: F401  (CI installs the scale extra: a missing Ray fails there)
    else:
        pytest.importorskip("ray", reason="the 'scale' extra is not installed")
    found = Path(sys.executable).with_name("ray")
    return str(found) if found.exists() else shutil.which("ray") or "ray"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def ray_cluster(tmp_path_factory):
    """A head and one worker node on loopback, each `ray start --block` in its own process group
    (stopping the group stops the node); their address."""
    ray = _ray_bin()
    port = _free_port()
    temp = Path(f"/tmp/rt{os.getpid()}")  # Ray's socket paths must stay short
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    common = ["--block", "--num-cpus=1", "--node-ip-address=127.0.0.1", "--disable-usage-stats"]
    procs = [subprocess.Popen([ray, "start", "--head", f"--port={port}", "--include-dashboard=false",
                               f"--temp-dir={temp}", *common], env=env, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    address = f"127.0.0.1:{port}"
    try:
        _wait_port(port, procs[0])
        procs.append(subprocess.Popen([ray, "start", f"--address={address}", *common], env=env,
                                      start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        _wait_nodes(address, 2)
        yield address
    finally:
        for p in reversed(procs):
            with_group(p, signal.SIGTERM)
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                with_group(p, signal.SIGKILL)
        shutil.rmtree(temp, ignore_errors=True)


def with_group(p: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(p.pid, sig)
    except ProcessLookupError:
        pass


def _wait_port(port: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, "the Ray head did not start"
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.5)
    raise AssertionError("the Ray head did not open its port")


def _wait_nodes(address: str, n: int, timeout: float = 120.0) -> None:
    code = ("import ray,time,sys\nray.init(address=sys.argv[1], logging_level='ERROR')\n"
            f"t=time.time()\nwhile len([x for x in ray.nodes() if x['Alive']]) < {n} and time.time()-t < {timeout}:\n"
            " time.sleep(0.5)\nsys.exit(0 if len([x for x in ray.nodes() if x['Alive']]) >= "
            f"{n} else 1)\n")
    got = subprocess.run([sys.executable, "-c", code, address], capture_output=True, text=True, timeout=timeout + 60)
    assert got.returncode == 0, got.stderr[-2000:]


def _batch_dir(root: Path) -> Path:
    """A batch folder whose run folders hold the recorded answers (a --replay batch reads them)."""
    (root / "spec.yaml").parent.mkdir(parents=True, exist_ok=True)
    (root / "spec.yaml").write_text(SPEC)
    out = root / "out"
    for folder, cassette in CACHES.items():
        (out / folder).mkdir(parents=True)
        CallCache(out / folder / "llm-cache.sqlite").import_json(CASSETTES / cassette)
    return out


def _untimed(p: Path) -> bytes:
    """A file's bytes without its clock readings: the solver's wall time in scenario.json, the
    OpenSCENARIO header's date."""
    data = p.read_bytes()
    if p.suffix == ".json":
        return re.sub(rb'"wall_time": [0-9.e-]+', b'"wall_time": 0', data)
    if p.suffix == ".xosc":
        return re.sub(rb'date="[^"]*"', b'date=""', data)
    return data


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): _untimed(p) for p in sorted(out.rglob("*"))
            if p.is_file() and p.name not in TIMED and not p.name.startswith("llm-cache")}


def test_a_batch_on_a_ray_cluster_equals_the_process_pools(tmp_path, ray_cluster) -> None:
    pytest.importorskip("scenic", reason="the 'driving' extra is not installed")
    pool_out = _batch_dir(tmp_path / "pool")
    pool = run_batch(tmp_path / "pool" / "spec.yaml", pool_out, workers=2, replay=True)
    assert pool.status == "done", [(b.folder, b.message) for b in pool.behaviors]
    ray_out = _batch_dir(tmp_path / "ray")
    on_ray = run_batch(tmp_path / "ray" / "spec.yaml", ray_out, ray=ray_cluster, replay=True)
    assert on_ray.status == "done", [(b.folder, b.message) for b in on_ray.behaviors]
    record = json.loads((ray_out / "batch.json").read_text())
    assert record["executor"] == "ray" and record["ray_address"] == ray_cluster and record["workers"] == 2
    verdicts = sorted(ray_out.glob("*/scenarios/*/verdict.json"))
    assert len(verdicts) == 3 and any(json.loads(v.read_text())["feasible"] for v in verdicts)
    a, b = _files(pool_out), _files(ray_out)
    assert sorted(a) == sorted(b)
    assert [k for k in a if a[k] != b[k]] == []
    for name in ("run.json", "summary.json"):  # the timed files agree on everything but time
        for folder in CACHES:
            x, y = (json.loads((o / folder / name).read_text()) for o in (pool_out, ray_out))
            for d in (x, y):
                for k in ("timings", "started", "finished", "usage", "usage_last", "wall_seconds", "settings"):
                    d.pop(k, None)
            assert x == y, name
