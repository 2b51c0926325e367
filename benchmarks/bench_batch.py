"""Batch efficiency: `regen batch` with replayed answers on 1 and 2 workers, on the local process
pool and on a local Ray cluster, through the same function the CLI runs (regen.batch.run_batch).

Ray: for each worker count n a head is started on loopback with n CPUs (`ray start --head
--num-cpus=n`, as a user's cluster is already running when a batch starts) and the batch is sent to
its address (`--ray HOST:PORT`); the cluster's start is timed apart and not counted. The batch's
wall time still holds the driver's connection and the cold Ray worker processes (their imports).

The batch is made from finished run folders (their behaviors, settings and model caches): each
becomes one entry of a spec, its llm-cache.sqlite copied into the batch's run folder, so nothing
asks a model. Efficiency per added worker = T(1) / (n * T(n)).

Usage:
    python benchmarks/bench_batch.py --runs /path/to/finished/runs [--limit 16] [--pictures] [--no-ray]

Target (issue 39): at least 0.8 per added worker, on the pool and on Ray.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import yaml

from regen.batch import run_batch


def spec_from_runs(runs: list[Path], pictures: bool) -> tuple[list[dict], list[Path]]:
    """One spec entry per finished run folder (its behavior and result settings), and the caches."""
    entries, caches, seen = [], [], set()
    for run in runs:
        m = json.loads((run / "run.json").read_text())
        b, s = m["behavior"], m["settings"]
        key = (b["text"], tuple(s["forced_causes"]), tuple(s["candidates"]), json.dumps(b["params"], sort_keys=True))
        if key in seen:
            continue
        seen.add(key)
        e = {"text": b["text"], "domain": b["domain"], "scenarios": s["max_scenarios"], "depth": s["depth"],
             "max_nodes": s["max_nodes"], "causes": s["causes"], "seed": s["seed"], "llm": s["llm"],
             "pictures": pictures}
        for k, v in (("cause", s["forced_causes"]), ("candidate", s["candidates"]), ("prior", s["prior"])):
            if v:
                e[k] = v
        params = b["params"]
        if "ego_template" in params:
            e["ego"] = params["ego_template"]
        if "reward" in params:
            e["reward"] = params["reward"]
        entries.append(e)
        caches.append(run / "llm-cache.sqlite")
    return entries, caches


def one_batch(entries: list[dict], caches: list[Path], *, workers: int, ray: str | None) -> tuple[float, int, int]:
    """Wall seconds, verified and total scenarios of one fresh batch."""
    from regen.batch.runner import folder_names
    from regen.batch.spec import plan, read_spec
    from regen.pipeline.request import behavior_to_generate, export_options

    with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
        root = Path(tmp)
        spec = root / "spec.yaml"
        spec.write_text(yaml.safe_dump({"behaviors": entries}, sort_keys=False))
        names = folder_names(plan(read_spec(spec)[0], behavior_to_generate, export_options))
        for name, cache in zip(names, caches, strict=True):
            (root / "out" / name).mkdir(parents=True)
            shutil.copy(cache, root / "out" / name / "llm-cache.sqlite")
        t0 = time.perf_counter()
        rec = run_batch(spec, root / "out", workers=workers, ray=ray, replay=True)
        wall = time.perf_counter() - t0
        verdicts = [json.loads(p.read_text()) for p in (root / "out").glob("*/scenarios/*/verdict.json")]
        failed = [b.folder for b in rec.behaviors if b.status != "done"]
        if failed:
            print(f"  ({len(failed)} behavior(s) did not finish: {', '.join(failed[:3])} ...)")
        return wall, sum(v["feasible"] for v in verdicts), len(verdicts)


@contextmanager
def local_cluster(cpus: int):
    """A Ray head on loopback with ``cpus`` CPUs (`ray start --head --block` in its own process
    group, stopped at the end); yields its address and the seconds it took to answer."""
    ray_bin = Path(sys.executable).with_name("ray")
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    temp = Path(f"/tmp/rb{os.getpid()}")  # Ray's socket paths must stay short
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    t0 = time.perf_counter()
    proc = subprocess.Popen([str(ray_bin), "start", "--head", "--block", f"--port={port}", f"--num-cpus={cpus}",
                             "--include-dashboard=false", "--node-ip-address=127.0.0.1", "--disable-usage-stats",
                             f"--temp-dir={temp}"], env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while True:
            if proc.poll() is not None:
                raise SystemExit("the Ray head did not start")
            with socket.socket() as sock:
                if sock.connect_ex(("127.0.0.1", port)) == 0:
                    break
            if time.perf_counter() - t0 > 120:
                raise SystemExit("the Ray head did not open its port in 120 s")
            time.sleep(0.2)
        address = f"127.0.0.1:{port}"
        ready = ("import ray, sys, time\nray.init(address=sys.argv[1], logging_level='ERROR')\n"
                 "t = time.time()\nwhile ray.available_resources().get('CPU', 0) < int(sys.argv[2]) "
                 "and time.time() - t < 120:\n    time.sleep(0.2)\n")
        subprocess.run([sys.executable, "-c", ready, address, str(cpus)], env=env, check=True, timeout=200,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        yield address, time.perf_counter() - t0
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
        shutil.rmtree(temp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=Path, required=True, help="a folder of finished run folders (each with run.json)")
    ap.add_argument("--limit", type=int, default=16, help="most behaviors in the batch")
    ap.add_argument("--pictures", action="store_true", help="draw pictures too")
    ap.add_argument("--no-ray", action="store_true", help="the process pool only")
    args = ap.parse_args()
    runs = sorted(p.parent for p in args.runs.glob("*/run.json"))
    entries, caches = spec_from_runs(runs, args.pictures)
    entries, caches = entries[:args.limit], caches[:args.limit]
    print(f"batch of {len(entries)} behaviors from {args.runs} (pictures: {args.pictures}), replayed answers")
    for label in ["pool"] + ([] if args.no_ray else ["ray"]):
        walls = {}
        for n in (1, 2):
            if label == "pool":
                wall, ok, total = one_batch(entries, caches, workers=n, ray=None)
                extra = ""
            else:
                with local_cluster(n) as (address, started):
                    wall, ok, total = one_batch(entries, caches, workers=n, ray=address)
                extra = f" (the cluster's start, not counted: {started:.1f} s)"
            walls[n] = wall
            print(f"{label}: {n} worker(s): {wall:.1f} s wall, {ok}/{total} verified, "
                  f"{ok / (wall / 60) / n:.1f} verified per core-minute{extra}")
        print(f"{label}: efficiency per added worker T(1)/(2 T(2)) = {walls[1] / (2 * walls[2]):.2f}")


if __name__ == "__main__":
    main()
