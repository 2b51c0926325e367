"""Graph expansion with the offline model: model calls, tokens and wall time at depth 1 and 2.

Usage: python benchmarks/bench_expand.py [--llm local] [--depths 1 2] [--domain driving]
Uses a fresh in-memory cache, so every call reaches the model.
"""

from __future__ import annotations

import argparse
import time

from regen.core.behavior import Behavior
from regen.expand import Limits, expand
from regen.llm import LLM

BEHAVIORS = {"driving": ("the ego-vehicle stops abruptly while driving forward", {}),
             "manipulation": ("the robot opens the door", {"reward": "open_door"})}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--llm", default="local")
    ap.add_argument("--domain", default="driving", choices=sorted(BEHAVIORS))
    ap.add_argument("--depths", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--causes", type=int, default=3)
    args = ap.parse_args()
    text, extra = BEHAVIORS[args.domain]
    for depth in args.depths:
        llm = LLM(args.llm, cache=None)
        t0 = time.perf_counter()
        g = expand(Behavior(text=text, domain=args.domain, params=extra), llm,
                   limits=Limits(max_depth=depth, max_nodes=12, max_causes=args.causes))
        wall = time.perf_counter() - t0
        t = llm.stats.total
        print(f"depth {depth}: {t.model_calls} model calls, {t.input_tokens} tokens in, "
              f"{t.output_tokens} out, {wall:.1f} s wall; {len(g.events()) - 1} causes, "
              f"{len(g.paths())} simulatable paths; stop: {g.stop_reason}")
        for purpose, s in llm.stats.by_purpose.items():
            print(f"    {purpose}: {s.model_calls} calls, {s.latency:.1f} s")


if __name__ == "__main__":
    main()
