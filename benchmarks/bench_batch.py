"""Batch efficiency: `regen batch` with replayed answers on 1 and 2 workers, on the local process
pool and on a local Ray instance, through the same function the CLI runs (regen.batch.run_batch).

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
import shutil
import tempfile
import time
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
    executors = [("pool", None)] + ([] if args.no_ray else [("ray", "auto")])
    for label, ray in executors:
        walls = {}
        for n in (1, 2):
            wall, ok, total = one_batch(entries, caches, workers=n, ray=ray)
            walls[n] = wall
            print(f"{label}: {n} worker(s): {wall:.1f} s wall, {ok}/{total} verified, "
                  f"{ok / (wall / 60) / n:.1f} verified per core-minute")
        print(f"{label}: efficiency per added worker T(1)/(2 T(2)) = {walls[1] / (2 * walls[2]):.2f}")


if __name__ == "__main__":
    main()
