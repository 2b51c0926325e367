"""Driving benchmark: per-scenario time split into solve, Scenic compile, simulation and drawing,
and simulated seconds per wall second, through the main job's stages (regen.pipeline.run_path).

Targets (issue 4): CP-SAT under 0.2 s per scenario; simulation at least 20x real time without
drawing. Run: python benchmarks/bench_driving.py [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import tempfile
from pathlib import Path

from regen.core import Behavior, CausePath, PathEntity
from regen.pipeline import run_path

CHAINS = [
    ("stop_abruptly", "a child runs across the road",
     [("child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})]),
    ("stop_abruptly", "an ambulance approaches from behind",
     [("ambulance", {"behavior": ["drive_forward"], "siren": ["on"], "target_speed": ["fast"],
                     "start_location": ["behind_adjacent_lane"]})]),
    ("slow_down", "a slow truck is ahead",
     [("truck", {"behavior": ["drive_forward"], "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})]),
    ("drive_forward", "the light turns green", [("traffic_light", {"light_state": ["red"]})]),
    ("change_lane", "a slow bus is ahead",
     [("bus", {"behavior": ["drive_forward"], "start_location": ["ahead_same_lane"], "target_speed": ["slow"]})]),
    ("stop_after_turn", "a pedestrian crosses",
     [("adult", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]})]),
    ("stop_in_intersection", "a car runs the red light",
     [("sedan", {"behavior": ["run_red_light"], "start_location": ["junction_cross_street"]}),
      ("traffic_light", {"light_state": ["green"]})]),
]


def _path(tid: str, cause: str, ents) -> CausePath:
    return CausePath(behavior=Behavior(text=f"ego: {tid}", domain="driving", params={"ego_template": tid}),
                     events=[cause, f"ego {tid}"],
                     entities=[PathEntity(asset=a, event=cause, properties=p) for a, p in ents])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--profile", action="store_true", help="cProfile the whole batch")
    args = ap.parse_args()
    rows = []
    prof = cProfile.Profile() if args.profile else None
    if prof:
        prof.enable()
    with tempfile.TemporaryDirectory() as tmp:
        for k, (tid, cause, ents) in enumerate(CHAINS):
            r = run_path(_path(tid, cause, ents), Path(tmp) / f"{k:02d}-{tid}")
            trace = r.trace()
            sim_s = trace.times[-1] if trace else 0.0
            t = r.timings
            rows.append((tid, r.verdict.status, t.get("solve", 0.0), t.get("compile", 0.0),
                         t.get("simulate", 0.0), t.get("render", 0.0), sim_s))
    if prof:
        prof.disable()
    print(f"{'template':22} {'verdict':14} {'solve[s]':>8} {'compile[s]':>10} {'sim[s]':>7} "
          f"{'draw[s]':>7} {'sim s/wall s':>12}")
    for tid, st, so, co, si, dr, sim_s in rows:
        rate = sim_s / si if si > 0 else 0.0
        print(f"{tid:22} {st:14} {so:8.3f} {co:10.2f} {si:7.2f} {dr:7.2f} {rate:12.1f}")
    sims = [r for r in rows if r[4] > 0]
    print(f"median solve {statistics.median(r[2] for r in rows):.3f} s (target < 0.2 s); "
          f"median compile {statistics.median(r[3] for r in sims):.2f} s; "
          f"simulated/wall (no drawing) {sum(r[6] for r in sims) / sum(r[4] for r in sims):.1f}x "
          f"(target >= 20x)")
    if prof:
        pstats.Stats(prof).sort_stats("cumulative").print_stats(25)


if __name__ == "__main__":
    main()
