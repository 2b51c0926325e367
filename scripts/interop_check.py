"""Check every exported driving scenario the way the interop work counts them, and print the counts.

Usage:
    python scripts/interop_check.py RUN [RUN ...]          # run folders (or scenario folders)
    python scripts/interop_check.py --chains DIR [RUN ...]  # also run every hand-written chain into DIR

The four checks per scenario (ASAM bundles, a start relative to the ego, the CARLA program,
the import round trip) are :mod:`regen.driving.interop.roundtrip`'s. Exit code 1 when any fails.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _folders(paths: list[Path]) -> list[Path]:
    out = []
    for p in paths:
        if (p / "scenario.xosc").is_file() and (p / "verdict.json").is_file():
            out.append(p)
        else:
            out += sorted(q.parent for q in p.glob("**/scenario.xosc") if (q.parent / "verdict.json").is_file())
    return out


def _chains(dest: Path) -> list[Path]:
    sys.path.insert(0, str(ROOT / "tests" / "support"))
    from driving_chains import FEASIBLE

    from regen.pipeline.stages import run_path

    out = []
    for key, chains in sorted(FEASIBLE.items()):
        for i, c in enumerate(chains):
            folder = dest / f"{key}-{i}"
            if not (folder / "verdict.json").is_file():
                run_path(c, folder, pictures=False)
            out.append(folder)
    return out


def main(argv: list[str]) -> int:
    from regen.driving.interop.roundtrip import check_folder

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", type=Path)
    ap.add_argument("--chains", type=Path, help="run every hand-written chain into this folder and check it too")
    args = ap.parse_args(argv)
    folders = _folders(args.runs) + (_chains(args.chains) if args.chains else [])
    if not folders:
        print("no scenario folders with a verdict and a scenario.xosc", file=sys.stderr)
        return 1
    maps: set[str] = set()
    checks = []
    for f in folders:
        c = check_folder(f, maps_seen=maps)
        checks.append(c)
        print(c.line(), flush=True)
    n = len(checks)
    rel = [c for c in checks if c.relative is not None]
    print(f"\n{n} scenarios ({len(maps)} distinct maps): ASAM no error {sum(not c.asam for c in checks)}/{n}; "
          f"relative start {sum(bool(c.relative) for c in rel)}/{len(rel)}; CARLA {sum(c.carla == 'ok' for c in checks)}/{n}; "
          f"round trip same verdict {sum(c.same_verdict for c in checks)}/{n}, largest position difference "
          f"{max(c.max_error for c in checks):.2f} m")
    return 0 if all(c.ok for c in checks) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
