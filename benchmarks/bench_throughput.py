"""Throughput of the main job from cached model answers: verified driving scenarios per
core-minute, with and without pictures, and the per-scenario split of the time (Scenic compile,
simulation, the causal check, drawing, exports).

Every job is a finished run replayed through the stage functions the CLI runs:
:func:`regen.pipeline.generate` with ``replay=True`` (no model call; a miss fails) and
``fresh=True`` on a temporary run folder that holds only the job's answers (``llm-cache.sqlite``).
The jobs: the recorded README job (``tests/data/cassettes/generate_driving.json``, three
scenarios), and with ``--run DIR`` (repeatable) finished run folders whose ``llm-cache.sqlite``
holds the answers and whose ``run.json`` the behavior and settings.

Each mode (pictures, no pictures) runs in a fresh process of its own, ``--rounds`` times over all
jobs, with one simulation worker: one core. The first round starts cold (imports, the model-free
caches of the process); a batch of many distinct jobs (``--run``) is the realistic figure. Later
rounds replay the very same scenarios again, so every in-process cache hits: an upper bound.
Core-minute = verified scenarios / (wall minutes x 1 core); the same over the process's CPU time
is printed too, since on a shared machine the wall clock also counts time spent waiting for a
core. Targets (issue 39): 60 per core-minute with pictures, 200 without.

Run: python benchmarks/bench_throughput.py [--run DIR ...] [--rounds N] [--mode pictures] [--profile]
(e.g. ``--run`` every finished one-cause run folder of an evaluation).
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASSETTE = ROOT / "tests" / "data" / "cassettes" / "generate_driving.json"
README_BEHAVIOR = {"text": "the ego-vehicle stops abruptly while driving forward", "domain": "driving"}
#: per-scenario timings shown [s], as the stages record them -> as printed
SPLIT = {"compile": "compile", "simulate": "simulate", "causal": "causal check", "render": "draw",
         "export": "export"}


def _cpu() -> float:
    """CPU time [s] of this process so far (user + system, every thread)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _jobs(runs: list[str]) -> list[dict]:
    """The jobs to replay: the recorded README job, then each finished run folder given."""
    jobs = [{"name": "readme (cassette)", "cassette": str(CASSETTE), "behavior": README_BEHAVIOR,
             "settings": {"llm": "local"}}]
    for d in runs:
        manifest = json.loads((Path(d) / "run.json").read_text())
        jobs.append({"name": Path(d).name, "cache": str(Path(d) / "llm-cache.sqlite"),
                     "behavior": manifest["behavior"], "settings": manifest["settings"]})
    return jobs


def _replay(job: dict, folder: Path, pictures: bool) -> tuple[list[dict], dict[str, float]]:
    """One job replayed into ``folder``: per scenario its verdict's status and timings, and the
    run's stage totals [s] (expand, ground, simulate, report)."""
    from regen.core.behavior import Behavior
    from regen.llm.cache import CallCache
    from regen.pipeline import RunSettings, generate

    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    if "cassette" in job:
        cache = CallCache(folder / "llm-cache.sqlite")
        cache.import_json(Path(job["cassette"]))
        cache.close()
    else:
        shutil.copy2(job["cache"], folder / "llm-cache.sqlite")
    settings = RunSettings.model_validate({**job["settings"], "pictures": pictures, "workers": 1})
    res = generate(Behavior.model_validate(job["behavior"]), folder, settings=settings, replay=True, fresh=True)
    if res.manifest.usage["total"].get("model_calls", 0):
        raise SystemExit(f"{job['name']}: the replay called the model")
    return ([{"status": o.verdict.status, "feasible": o.verdict.feasible, "timings": o.timings}
             for o in res.outcomes], dict(res.manifest.timings))


def _cache_stats() -> dict[str, dict[str, int]]:
    """Hits and misses of the process's Scenic caches so far (statements parsed, modules
    translated), where the driving domain is installed."""
    try:
        from regen.driving.simulation import compile_cache, parse_cache
    except ImportError:
        return {}
    return {"parse": dict(parse_cache.stats), "translate": dict(compile_cache.stats)}


def worker(pictures: bool, rounds: int, runs: list[str], profile: bool) -> None:
    """In a fresh process: replay every job ``rounds`` times; print one JSON line per round."""
    t_import = time.perf_counter()
    import regen.pipeline  # noqa: F401  (the import a CLI process pays once)
    from regen.errors import CacheMissError

    import_s = time.perf_counter() - t_import
    jobs = _jobs(runs)
    prof = None
    if profile:
        import cProfile

        prof = cProfile.Profile()
    with tempfile.TemporaryDirectory(prefix="regen-throughput-") as tmp:
        for k in range(rounds):
            scenarios, stages, skipped, wall, cpu = [], {}, [], 0.0, 0.0
            for i, job in enumerate(jobs):
                w0, c0 = time.perf_counter(), _cpu()
                if prof:
                    prof.enable()
                try:
                    done, totals = _replay(job, Path(tmp) / f"job{i}", pictures)
                except CacheMissError as exc:  # answers recorded for older prompts: not counted
                    print(f"skipped {job['name']}: {exc}", file=sys.stderr)
                    skipped.append(job["name"])
                    continue
                finally:
                    if prof:
                        prof.disable()
                wall, cpu = wall + time.perf_counter() - w0, cpu + _cpu() - c0
                scenarios += done
                for stage, sec in totals.items():
                    stages[stage] = stages.get(stage, 0.0) + sec
            print(json.dumps({"round": k, "import": import_s, "wall": wall, "cpu": cpu, "scenarios": scenarios,
                              "stages": stages, "skipped": skipped, "jobs": len(jobs) - len(skipped),
                              "caches": _cache_stats()}), flush=True)
    if prof:
        import pstats

        pstats.Stats(prof, stream=sys.stderr).sort_stats("cumulative").print_stats(30)


def _rate(n: int, seconds: float) -> float:
    """Scenarios per core-minute on one core."""
    return n / (seconds / 60.0) if seconds > 0 else 0.0


def _report(mode: str, rows: list[dict]) -> None:
    """The figures of one mode: cold round, warm rounds, all rounds, and the per-scenario split."""
    print(f"\n== {mode} (one core; import of regen.pipeline {rows[0]['import']:.2f} s, not counted)")
    if rows[0]["skipped"]:
        print(f"skipped (their answers miss today's prompts): {', '.join(rows[0]['skipped'])}")
    print(f"{'rounds':10} {'scenarios':>9} {'verified':>8} {'wall[s]':>8} {'cpu[s]':>7} "
          f"{'verified/core-min (wall)':>25} {'(cpu)':>7}")
    groups = [("cold", rows[:1]), ("warm", rows[1:]), ("all", rows)]
    for name, group in groups:
        if not group:
            continue
        sc = [s for r in group for s in r["scenarios"]]
        ok = sum(s["feasible"] for s in sc)
        wall, cpu = sum(r["wall"] for r in group), sum(r["cpu"] for r in group)
        print(f"{name:10} {len(sc):9d} {ok:8d} {wall:8.2f} {cpu:7.2f} {_rate(ok, wall):25.1f} {_rate(ok, cpu):7.1f}")
        jobs = sum(r.get("jobs", 0) for r in group)
        if jobs and ok:
            print(f"{'':10} cpu per job {cpu / jobs:.2f} s, per verified scenario {cpu / ok:.2f} s "
                  f"({jobs} jobs)")
    for name, group in groups[:2]:
        sc = [s for r in group for s in r["scenarios"]]
        if not sc:
            continue
        cells = []
        for key, label in SPLIT.items():
            vals = [s["timings"][key] for s in sc if key in s["timings"]]
            if vals:
                cells.append(f"{label} {statistics.mean(vals):.3f}/{statistics.median(vals):.3f}")
        print(f"  per scenario, {name} (mean/median [s, wall]): " + ", ".join(cells))
        stages = {k: sum(r["stages"].get(k, 0.0) for r in group) for k in group[0]["stages"]}
        print(f"  stage totals, {name} [s, wall]: " + ", ".join(f"{k} {v:.2f}" for k, v in stages.items()))
        caches = group[-1].get("caches") or {}
        if caches:  # counts so far in the process: the last round's
            print(f"  Scenic caches after {name} (hits/misses, and read from the kept files): "
                  + ", ".join(f"{k} {v['hits']}/{v['misses']}" + (f", {v['disk']} from disk" if "disk" in v else "")
                              for k, v in caches.items()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=1,
                    help="replays of all jobs per mode; the first is cold, later ones replay the same "
                         "scenarios again (optimistic: every in-process cache hits)")
    ap.add_argument("--run", action="append", default=[], help="a finished run folder to replay too")
    ap.add_argument("--profile", action="store_true", help="cProfile the replays (printed to stderr)")
    ap.add_argument("--mode", choices=["pictures", "no-pictures"], help="only this mode")
    ap.add_argument("--worker", choices=["pictures", "no-pictures"], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker == "pictures", args.rounds, args.run, args.profile)
        return
    print(f"jobs: {', '.join(j['name'] for j in _jobs(args.run))}; rounds per mode: {args.rounds}")
    for mode in [args.mode] if args.mode else ["pictures", "no-pictures"]:
        cmd = [sys.executable, __file__, "--worker", mode, "--rounds", str(args.rounds)]
        cmd += [a for d in args.run for a in ("--run", d)] + (["--profile"] if args.profile else [])
        out = subprocess.run(cmd, check=True, text=True, stdout=subprocess.PIPE).stdout
        _report(mode, [json.loads(line) for line in out.splitlines() if line.startswith("{")])


if __name__ == "__main__":
    main()
