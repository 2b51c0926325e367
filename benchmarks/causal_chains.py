"""The but-for check over the hand-written driving chains (tests/support/driving_chains.py),
through the main job's stages (regen.pipeline.run_path, rule-based grounding, no model): per
chain the FSM status, the causal part and what the reference driver did with and without the
cause; then the counts. Run: python benchmarks/causal_chains.py [--only TEXT] [--keep DIR]

``--keep DIR`` keeps the scenarios as run folders, one per ego template (DIR/<template>/run.json
naming the chains' behavior, DIR/<template>/scenarios/NN-<cause>/), so that other commands read
them: ``regen eval --coverage DIR``, ``regen test DIR/<template> --policy idm``.
"""

from __future__ import annotations

import argparse
import collections
import json
import re
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "support"))
from driving_chains import FEASIBLE  # noqa: E402

from regen.pipeline import run_path  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="only chains whose cause contains this text")
    ap.add_argument("--keep", default="", help="keep the scenarios as run folders under this folder")
    args = ap.parse_args()
    counts: collections.Counter[str] = collections.Counter()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for template, paths in FEASIBLE.items():
            base = Path(args.keep) / template if args.keep else Path(tmp) / template
            for i, path in enumerate(paths):
                cause = path.events[0]
                if args.only and args.only not in cause:
                    continue
                slug = re.sub(r"[^a-z0-9]+", "-", cause.lower()).strip("-")[:40]
                if args.keep and not (base / "run.json").exists():
                    base.mkdir(parents=True, exist_ok=True)
                    manifest = {"behavior": path.behavior.model_dump(mode="json"), "status": "done",
                                "settings": {"llm": "none (hand-written chains, rule-based grounding)"},
                                "domain_settings": {"ego_template": template}}
                    (base / "run.json").write_text(json.dumps(manifest, indent=1))
                out = run_path(path, base / "scenarios" / f"{i + 1:02d}-{slug}", pictures=False)
                v, c = out.verdict, out.verdict.causal
                status = c.status if c is not None else "none"
                counts[(v.status, status)] += 1
                print(f"{template:22s} {cause[:48]:48s} {v.status:22s} {status}")
                if c is not None and status != "caused":
                    print(f"{'':23s}{c.reason[:160]}")
    print()
    for (fsm, causal), n in sorted(counts.items()):
        print(f"{n:3d}  {fsm:22s} {causal}")
    verified = sum(n for (fsm, _), n in counts.items() if fsm.startswith("verified"))
    caused = sum(n for (fsm, c), n in counts.items() if fsm.startswith("verified") and c == "caused")
    print(f"verified {verified}, of which caused {caused}; {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
