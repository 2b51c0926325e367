"""Manipulation benchmark: placement, scene build, rollout time per scenario; physics steps/s.

    python benchmarks/bench_manipulation.py [--contexts 3] [--render]

Grounds every behavior in ``--contexts`` generated contexts (rule-based placement, no model),
simulates each with the scripted controller, verifies the FSM and prints one line per scenario
and a summary. ``--render`` also times the labeled strip/GIF of the first context (written to a
temp folder).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
from pathlib import Path

from regen.core import Behavior, CausePath, PathEntity
from regen.manipulation.world.tasks import BEHAVIORS
from regen.pipeline import run_path

# three contexts per behavior: (cause, context assets)
CONTEXTS: dict[str, list[tuple[str, list[str]]]] = {
    "open_door": [("the pet wants to come in", ["pet"]), ("a guest rings the bell", ["adult", "plant"]),
                  ("the room is stuffy", ["child", "book"])],
    "close_window": [("it starts to rain", ["plant", "book"]), ("the pet might jump out", ["pet"]),
                     ("the baby is cold", ["child", "toy"])],
    "adjust_faucet": [("the dishes are dirty", ["dishes"]), ("the plant is dry", ["plant", "cup"]),
                      ("the fruit must be washed", ["fruit"])],
    "turn_oven_knob": [("dinner must be cooked", ["frozen_vegetables"]),
                       ("the dishes must be warmed", ["dishes", "adult"]), ("guests are hungry", ["child", "cup"])],
    "open_cabinet": [("guests want a drink", ["cup", "adult"]), ("the table must be set", ["dishes"]),
                     ("someone is thirsty", ["bottle", "child"])],
    "pull_drawer": [("the clothes must be put away", ["clothes"]), ("a book is needed", ["book", "adult"]),
                    ("the child looks for a toy", ["child", "toy"])],
    "tilt_display": [("sunlight glares on the screen", ["laptop", "adult"]),
                     ("the child watches a film", ["child", "toy"]), ("a call starts", ["cup", "plant"])],
    "turn_on_lamp": [("it is getting dark", ["book", "child"]), ("the pet is afraid of the dark", ["pet"]),
                     ("a guest arrives in the evening", ["adult", "cup"])],
    "store_item": [("the room must be tidied", ["toy", "trash_can"]), ("the book is finished", ["book"]),
                   ("the cup is dry", ["cup", "plant"])],
    "retrieve_from_fridge": [("someone is thirsty", ["bottle", "child"]), ("dessert time", ["fruit", "adult"]),
                             ("dinner needs vegetables", ["frozen_vegetables", "cup"])],
    "retrieve_from_box": [("the child wants a toy", ["child"]), ("the pet wants its toy", ["pet"]),
                          ("the shelf must be filled", ["book", "plant"])],
    "carry_bucket": [("the plant needs water", ["plant"]), ("the floor must be mopped", ["adult"]),
                     ("the pet needs water", ["pet", "toy"])],
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--contexts", type=int, default=3)
    ap.add_argument("--render", action="store_true")
    args = ap.parse_args()
    rows = []
    for bid, contexts in CONTEXTS.items():
        b = BEHAVIORS[bid]
        for seed, (cause, assets) in enumerate(contexts[: args.contexts]):
            path = CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": bid}),
                             events=[cause, b.text],
                             entities=[PathEntity(asset=a, event=cause) for a in assets])
            out = Path(tempfile.mkdtemp(prefix=f"regen-{bid}-"))
            res = run_path(path, out, seed=seed, pictures=args.render and seed == 0)  # the main job's stages
            steps = res.trace().meta["physics_steps"]
            t = res.timings
            sim_s = steps / 240.0
            sps = steps / t["rollout"]
            row = {"behavior": bid, "context": cause, "verdict": res.verdict.status,
                   "placement": t["solve"], "ground": t["ground"], "build": t["build"],
                   "rollout": t["rollout"], "sim_s": sim_s, "steps_per_s": sps}
            rows.append(row)
            print(f"{bid:22s} {cause[:32]:32s} {res.verdict.status:15s} placement {row['placement'] * 1e3:6.1f} ms"
                  f"  build {row['build']:.2f} s  rollout {row['rollout']:.2f} s ({sim_s:.1f} s sim,"
                  f" {sps:,.0f} steps/s)", flush=True)
            if "render" in t:
                print(f"{'':22s} render strip+GIF {t['render']:.2f} s -> {out}")
            else:  # nothing in it to look at: not left in /tmp
                shutil.rmtree(out, ignore_errors=True)
    ok = sum(r["verdict"] == "verified" for r in rows)
    per_behavior: dict[str, int] = {}
    for r in rows:
        per_behavior[r["behavior"]] = per_behavior.get(r["behavior"], 0) + (r["verdict"] == "verified")
    print(f"\nverified {ok}/{len(rows)} scenarios; behaviors verified in all contexts: "
          f"{sum(v == args.contexts for v in per_behavior.values())}/{len(per_behavior)}")
    for key in ("placement", "build", "rollout", "steps_per_s"):
        vals = [r[key] for r in rows]
        print(f"{key:12s} median {statistics.median(vals):10.3f}  max {max(vals):10.3f}")


if __name__ == "__main__":
    main()
