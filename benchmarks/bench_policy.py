"""Policy-in-the-loop benchmark: simulated seconds per wall second without drawing, and test
throughput, for the built-in policies on the hand-written driving chains.

Every figure is taken with the policy in its own process, as ``regen test`` runs it
(:mod:`regen.harness.process`); the episode is also timed with the policy called in the
benchmark's own process, and the cost of one call over the pipe is printed per step.

Test throughput is measured twice: per episode (program compiled, oracle included) and as
``regen test`` runs it, :func:`regen.harness.suite.run_tests` over a run folder holding
the scenarios (tests per minute, with and without the GIF of each failure).

Per scenario the Scenic program is compiled once (cached across policies and episodes, as
``regen test`` does); "episode" time is scene generation + the Newtonian loop with the policy +
building the trace; "test" time adds the oracle (collisions and FSM ego states).

Target (issue 13): at least 50x real time. Run: python benchmarks/bench_policy.py [--repeats N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))
from driving_chains import FEASIBLE  # noqa: E402  (the hand-written chains)

from regen.driving.testing.harness import DrivingHarness  # noqa: E402
from regen.driving.testing.loop import prepare, run_policy  # noqa: E402
from regen.driving.testing.policies import BUILTIN, load_policy  # noqa: E402
from regen.harness.oracle import judge  # noqa: E402
from regen.harness.pictures import keep_failures  # noqa: E402
from regen.harness.process import PolicyProcess  # noqa: E402
from regen.harness.suite import run_tests  # noqa: E402
from regen.pipeline import run_path  # noqa: E402
from regen.runfolder import RunFolder, ScenarioFolder  # noqa: E402

HARNESS = DrivingHarness()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3, help="episodes per policy and scenario")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="regen-bench-policy-"))
    scenarios = []
    for key, paths in FEASIBLE.items():
        folder = work / RunFolder.SCENARIOS / f"{key}-0"  # work/ is a run folder for run_tests
        if run_path(paths[0], folder, pictures=False).verdict.feasible:
            scenarios.append((key, ScenarioFolder(folder).scenario()))
    print(f"{'scenario':22s} {'policy':15s} {'compile [s]':>11s} {'in-proc [s]':>11s} {'episode [s]':>11s} "
          f"{'step [ms]':>9s} {'x real time':>11s} {'test [s]':>9s}")
    speeds, tests, total_test, sim_total, per_step, inproc_speeds = [], 0, 0.0, 0.0, [], []
    for key, sc in scenarios:
        t0 = time.perf_counter()
        prep = prepare(sc)
        compile_s = time.perf_counter() - t0
        for name in BUILTIN:
            ep_times, in_times, test_times, steps = [], [], [], 0
            with PolicyProcess(HARNESS, name) as proc:  # what regen test runs: the policy in its own process
                proc.start()
                for _ in range(args.repeats):
                    t1 = time.perf_counter()
                    episode = run_policy(prep, proc)
                    t2 = time.perf_counter()
                    judge(HARNESS, sc, episode, folder=key)
                    t3 = time.perf_counter()
                    ep_times.append(t2 - t1)
                    test_times.append(t3 - t1)
                    steps = episode.steps
                    per_step.append(episode.timings["policy"] / max(1, episode.steps))
            for _ in range(args.repeats):  # the same policy called in this process, for comparison
                t1 = time.perf_counter()
                run_policy(prep, load_policy(name))
                in_times.append(time.perf_counter() - t1)
            simulated = episode.trace.times[-1]
            ep = statistics.median(ep_times)
            speeds.append(simulated / ep)
            inproc_speeds.append(simulated / statistics.median(in_times))
            tests += len(test_times)
            total_test += sum(test_times)
            sim_total += simulated * len(test_times)
            print(f"{key:22s} {name:15s} {compile_s:11.2f} {statistics.median(in_times):11.3f} {ep:11.3f} "
                  f"{1000 * statistics.median(per_step[-len(ep_times):]):9.3f} {simulated / ep:11.0f} "
                  f"{statistics.median(test_times):9.3f}  ({steps} steps)")
            compile_s = 0.0  # cached after the first policy
    print(f"\nsimulation speed without drawing, policy in its own process: median "
          f"{statistics.median(speeds):.0f}x real time, min {min(speeds):.0f}x (target >= 50x); "
          f"in the harness's process: median {statistics.median(inproc_speeds):.0f}x")
    print(f"policy call over the pipe (observation out, action back, the policy's own time included): "
          f"median {1000 * statistics.median(per_step):.3f} ms per step")
    print(f"test throughput (program compiled, per scenario variant): {tests / total_test:.1f} tests/s, "
          f"{sim_total / total_test:.0f} simulated s per wall s")
    suite_throughput(work)


def suite_throughput(run: Path) -> None:
    """Tests per minute of run_tests over the run folder, per built-in policy: the policy process
    started, every case written as it finishes (as ``regen test`` does)."""
    print(f"\nregen test over {run} (run_tests, every scenario once per policy):")
    print(f"{'policy':15s} {'tests':>5s} {'failed':>6s} {'wall [s]':>9s} {'tests/min':>9s} "
          f"{'with GIFs [s]':>13s} {'tests/min':>9s}")
    for name in BUILTIN:
        t0 = time.perf_counter()
        report = run_tests(run, name, out=run / RunFolder.TESTS / f"{name}-plain")
        plain = time.perf_counter() - t0
        t1 = time.perf_counter()
        drawn_out = run / RunFolder.TESTS / name
        run_tests(run, name, out=drawn_out, on_episode=keep_failures(drawn_out, HARNESS, policy=name))
        drawn = time.perf_counter() - t1
        n, failed = len(report.ran), report.summary()["failed"]
        print(f"{name:15s} {n:5d} {failed:6d} {plain:9.2f} {60 * n / plain:9.0f} {drawn:13.2f} "
              f"{60 * n / drawn:9.0f}")


if __name__ == "__main__":
    main()
