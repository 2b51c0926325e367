"""Check every exported driving scenario the way the interop issue counts them, and print the counts.

Usage:
    python scripts/interop_check.py RUN [RUN ...]          # run folders (or scenario folders)
    python scripts/interop_check.py --chains DIR [RUN ...]  # also run every hand-written chain into DIR

For each scenario folder with a verdict and a ``scenario.xosc``:

1. **ASAM**: the OpenSCENARIO XML and OpenDRIVE checker bundles (``.venv-qc``) report no error on the
   ``.xosc`` and its ``.xodr`` (maps with the same content are checked once);
2. **relative start**: where the scenario has a trigger relative to the ego (any kind but time), the
   ``.xosc`` starts at least one event on a condition whose triggering or reference entity is the ego;
3. **CARLA**: ``scenario.carla.scenic`` compiles in 2D mode and every object's start lies within
   1 m of a waypoint of CARLA's own parse of the exported map (y flipped), with the ``carla`` client;
4. **round trip**: ``regen import`` of the ``.xosc`` gives the same verdict status, and the largest
   distance between an actor's original and imported positions over all steps.

Exit code 1 when any check fails.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import xml.etree.ElementTree as ET
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


def _relative_ok(folder: Path) -> bool | None:
    """None: the scenario has no relative trigger; else whether the .xosc starts one on the ego."""
    from regen.core.scenario import Scenario
    from regen.driving.grounding.rules import plans_for
    from regen.runfolder import ScenarioFolder

    sc: Scenario | None = ScenarioFolder(folder).scenario()
    if sc is None:
        return False
    _, plans = plans_for(sc)
    if not any(p.trigger is not None and p.trigger.kind != "time" for p in plans if p.name != "ego"):
        return None
    root = ET.parse(folder / "scenario.xosc").getroot()
    for ev in root.iter("Event"):
        for cond in ev.iter("ByEntityCondition"):
            refs = {r.get("entityRef") for r in cond.findall("TriggeringEntities/EntityRef")}
            refs |= {c.get("entityRef") for c in cond.iter() if c.get("entityRef")}
            if "ego" in refs:
                return True
    return False


def _carla_ok(folder: Path) -> str:
    import scenic

    try:
        import carla
    except ImportError:
        return "no carla client"
    program = folder / "scenario.carla.scenic"
    scene, _ = scenic.scenarioFromFile(str(program), mode2D=True).generate(maxIterations=1)
    xodr = next(folder.glob("*.xodr"))
    world = carla.Map(xodr.stem, xodr.read_text())
    for o in scene.objects:
        x, y = o.position.x, o.position.y
        wp = world.get_waypoint(carla.Location(x=x, y=-y, z=0.0), project_to_road=True, lane_type=carla.LaneType.Any)
        if wp is None or math.hypot(wp.transform.location.x - x, -wp.transform.location.y - y) >= 1.0:
            return f"{o.name} off CARLA's map"
    return "ok"


def _round_trip(folder: Path) -> tuple[bool, float, str]:
    import numpy as np

    from regen.core.trace import Trace
    from regen.core.verdict import Verdict
    from regen.pipeline.imports import import_file
    from regen.runfolder import read_model

    first = read_model(folder / "verdict.json", Verdict).value
    with tempfile.TemporaryDirectory() as tmp:
        back = import_file(folder / "scenario.xosc", Path(tmp) / "run", pictures=False).outcomes[0]
        a = Trace.model_validate_json((folder / "trace.json").read_text())
        b = Trace.model_validate_json((back.path / "trace.json").read_text())
        err = 0.0
        for name, ta in a.actors.items():
            tb = b.actors.get(name)
            if tb is None or not ta.x:
                continue
            n = min(len(ta.x), len(tb.x))
            err = max(err, float(np.hypot(np.subtract(ta.x[:n], tb.x[:n]), np.subtract(ta.y[:n], tb.y[:n])).max()))
    same = first is not None and back.verdict.status == first.status
    return same, err, back.verdict.status


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
    import hashlib

    from regen.driving.export.qc import check_file

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", type=Path)
    ap.add_argument("--chains", type=Path, help="run every hand-written chain into this folder and check it too")
    args = ap.parse_args(argv)
    folders = _folders(args.runs) + (_chains(args.chains) if args.chains else [])
    if not folders:
        print("no scenario folders with a verdict and a scenario.xosc", file=sys.stderr)
        return 1
    seen: set[str] = set()
    counts = {"scenarios": 0, "asam_ok": 0, "maps": 0, "maps_ok": 0, "relative": 0, "relative_ok": 0,
              "carla_ok": 0, "round_trip_same": 0}
    worst = 0.0
    for f in folders:
        counts["scenarios"] += 1
        xosc = check_file(f / "scenario.xosc")
        asam = not (xosc.errors or xosc.failed)
        counts["asam_ok"] += asam
        for xodr in f.glob("*.xodr"):
            digest = hashlib.sha256(xodr.read_bytes()).hexdigest()
            if digest not in seen:
                seen.add(digest)
                r = check_file(xodr)
                counts["maps"] += 1
                counts["maps_ok"] += not (r.errors or r.failed)
        rel = _relative_ok(f)
        counts["relative"] += rel is not None
        counts["relative_ok"] += bool(rel)
        carla = _carla_ok(f)
        counts["carla_ok"] += carla == "ok"
        same, err, status = _round_trip(f)
        counts["round_trip_same"] += same
        worst = max(worst, err)
        print(f"{'ok  ' if asam and rel is not False and carla == 'ok' and same else 'FAIL'} {f}: asam "
              f"{'ok' if asam else xosc.summary()}; relative start {'-' if rel is None else rel}; carla {carla}; "
              f"round trip {status} (max {err:.2f} m)", flush=True)
    n = counts["scenarios"]
    print(f"\n{n} scenarios: ASAM .xosc {counts['asam_ok']}/{n}, distinct maps {counts['maps_ok']}/{counts['maps']}; "
          f"relative start {counts['relative_ok']}/{counts['relative']}; CARLA {counts['carla_ok']}/{n}; "
          f"round trip same verdict {counts['round_trip_same']}/{n}, largest position difference {worst:.2f} m")
    ok = (counts["asam_ok"] == n and counts["maps_ok"] == counts["maps"] and counts["relative_ok"] == counts["relative"]
          and counts["carla_ok"] == n and counts["round_trip_same"] == n)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
