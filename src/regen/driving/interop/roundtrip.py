"""Whether an exported driving scenario runs elsewhere and comes back, checked the way the
interop work counts it (``scripts/interop_check.py`` prints the counts over runs; the recorded
main job's test checks every scenario of it):

1. **ASAM**: the OpenSCENARIO XML and OpenDRIVE checker bundles (``.venv-qc``) report no error on
   the ``.xosc`` and its ``.xodr``;
2. **relative start**: where the scenario has a trigger relative to the ego (any kind but time),
   the ``.xosc`` starts at least one event on a condition whose triggering or reference entity is
   the ego;
3. **CARLA**: ``scenario.carla.scenic`` compiles in 2D mode and every object's start lies within
   1 m of a waypoint of CARLA's own parse of the exported map (y flipped), with the ``carla``
   client;
4. **round trip**: ``regen import`` of the ``.xosc`` gives the same verdict status; the largest
   distance between an actor's original and imported positions over all steps.

Imports: this domain's export, grounding and the shared pipeline stages (lazily).
"""

from __future__ import annotations

import math
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class InteropCheck:
    folder: Path
    asam: list[str] = field(default_factory=list)  # files with an error-level issue, with the summary
    relative: bool | None = None  # None: the scenario has no relative trigger
    carla: str = ""  # 'ok', 'no carla client' or what is off the map
    same_verdict: bool = False
    status_back: str = ""
    max_error: float = 0.0  # [m]

    @property
    def ok(self) -> bool:
        return not self.asam and self.relative is not False and self.carla == "ok" and self.same_verdict

    def line(self) -> str:
        rel = "-" if self.relative is None else self.relative
        return (f"{'ok  ' if self.ok else 'FAIL'} {self.folder}: asam {'; '.join(self.asam) or 'ok'}; relative start "
                f"{rel}; carla {self.carla}; round trip {self.status_back} (max {self.max_error:.2f} m)")


def relative_start(folder: Path) -> bool | None:
    """None: the scenario has no trigger relative to the ego; else whether the .xosc starts an
    event on a condition on the ego."""
    from regen.driving.grounding.rules import plans_for
    from regen.runfolder import ScenarioFolder

    sc = ScenarioFolder(folder).scenario()
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


def carla_check(folder: Path) -> str:
    """'ok' when the CARLA program compiles and every start lies on CARLA's map."""
    import scenic

    try:
        import carla
    except ImportError:
        return "no carla client"
    scene, _ = scenic.scenarioFromFile(str(folder / "scenario.carla.scenic"), mode2D=True).generate(maxIterations=1)
    xodr = next(folder.glob("*.xodr"))
    world = carla.Map(xodr.stem, xodr.read_text())
    for o in scene.objects:
        x, y = o.position.x, o.position.y
        wp = world.get_waypoint(carla.Location(x=x, y=-y, z=0.0), project_to_road=True, lane_type=carla.LaneType.Any)
        if wp is None or math.hypot(wp.transform.location.x - x, -wp.transform.location.y - y) >= 1.0:
            return f"{o.name} off CARLA's map"
    return "ok"


def round_trip(folder: Path) -> tuple[bool, float, str]:
    """(same verdict status, largest position difference [m], the imported status)."""
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
    return first is not None and back.verdict.status == first.status, err, back.verdict.status


def check_folder(folder: Path, *, maps_seen: set[str] | None = None) -> InteropCheck:
    """All four checks of one scenario folder (``maps_seen``: digests of maps already checked)."""
    import hashlib

    from regen.driving.interop.qc import check_file

    out = InteropCheck(folder=folder)
    files = [folder / "scenario.xosc"]
    for xodr in folder.glob("*.xodr"):
        digest = hashlib.sha256(xodr.read_bytes()).hexdigest()
        if maps_seen is None or digest not in maps_seen:
            files.append(xodr)
            if maps_seen is not None:
                maps_seen.add(digest)
    for f in files:
        r = check_file(f)
        if r.errors or r.failed:
            out.asam.append(r.summary())
    out.relative = relative_start(folder)
    out.carla = carla_check(folder)
    out.same_verdict, out.max_error, out.status_back = round_trip(folder)
    return out


__all__ = ["InteropCheck", "carla_check", "check_folder", "relative_start", "round_trip"]
