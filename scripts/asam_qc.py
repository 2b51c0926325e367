"""Run the ASAM Quality Checker bundles over every exported .xodr and .xosc under the given run
folders (or files) and print one line per file and the totals.

Usage: python scripts/asam_qc.py RUN [RUN ...]   (the checkers come from .venv-qc; see setup.sh)
Exit code 1 when any file has an error-level issue or a checker that failed.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

from regen.driving.interop.qc import check_file


def main(args: list[str]) -> int:
    files: list[Path] = []
    for a in args:
        p = Path(a)
        files += [p] if p.is_file() else sorted(q for q in p.rglob("*") if q.suffix in (".xodr", ".xosc"))
    bad = 0
    seen_maps: set[str] = set()
    for f in files:
        if f.suffix == ".xodr":  # a generated map is copied beside every scenario (with its lights' signals)
            digest = hashlib.sha256(f.read_bytes()).hexdigest()
            if digest in seen_maps:
                continue
            seen_maps.add(digest)
        r = check_file(f)
        bad += bool(r.errors or r.failed)
        print(("FAIL " if r.errors or r.failed else "ok   ") + f"{f}: " + r.summary().split(": ", 1)[1])
        for i in r.errors:
            print(f"      {i.checker}: {i.description} {'; '.join(i.where)[:200]}")
    print(f"{len(seen_maps)} maps and {sum(f.suffix == '.xosc' for f in files)} scenarios checked; {bad} with errors")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
