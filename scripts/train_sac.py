"""Train SAC on one manipulation behavior, then run the policy in generated contexts.

    python scripts/train_sac.py --behavior turn_on_lamp --steps 20000

Prints the training wall time and, per generated context, the FSM verdict. The policy is
cached under the user cache dir (``regen.paths.cache_dir('policies')``); ``--retrain`` ignores it.
"""

from __future__ import annotations

import argparse
import time

from regen.core import Behavior, CausePath, PathEntity
from regen.manipulation.grounding.ground import ground_path
from regen.manipulation.simulation.run import rollout
from regen.manipulation.simulation.sac import train_sac
from regen.verify import check_fsm

CONTEXTS = [
    (["it is getting dark in the reading corner", "the robot turns on the lamp"], ["book", "child"]),
    (["the pet is afraid of the dark", "the robot turns on the lamp"], ["pet", "toy"]),
    (["a guest arrives in the evening", "the robot turns on the lamp"], ["adult", "cup"]),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--behavior", default="turn_on_lamp")
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--retrain", action="store_true")
    args = ap.parse_args()
    model, info = train_sac(args.behavior, steps=args.steps, seed=args.seed, retrain=args.retrain)
    print(f"SAC {args.behavior}: {args.steps} steps, training wall time {info['train_seconds']:.1f} s"
          f"{' (cached policy)' if info['cached'] else ''}")
    wins = 0
    for i, (events, assets) in enumerate(CONTEXTS):
        path = CausePath(behavior=Behavior(text=events[-1], domain="manipulation", params={"reward": args.behavior}),
                         events=events, entities=[PathEntity(asset=a, event=events[0]) for a in assets])
        scenario = ground_path(path, seed=i)
        t0 = time.perf_counter()
        result = rollout(scenario, policy=model)
        verdict = check_fsm(scenario, result.trace)
        wins += verdict.status == "verified"
        print(f"context {i + 1} ({', '.join(assets)}): {verdict.status} - {verdict.reason} "
              f"[{time.perf_counter() - t0:.1f} s]")
    print(f"policy verified in {wins}/{len(CONTEXTS)} generated contexts")


if __name__ == "__main__":
    main()
