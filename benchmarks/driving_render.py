"""How long the driving pictures and the OpenSCENARIO export take, and how big the GIF is.

Run: ``python benchmarks/driving_render.py`` (uses a temporary cache dir; prints its figures).
Targets: drawing must not dominate a run (a few seconds for a 20 s scenario), GIF under ~2 MB.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np


def _run(map_name: str, map_path: Path, seconds: float, dt: float = 0.05):
    from regen.core.behavior import Behavior
    from regen.core.scenario import FSM, Entity, Scenario
    from regen.core.trace import ActorTrack, Trace
    from regen.core.verdict import StageResult, Verdict

    t = np.round(np.arange(0, seconds + 1e-9, dt), 6)
    n = len(t)
    # the generated four-way map's junction is where the file puts it: centre of its bounds
    cx = 162.0 if map_name == "four_way" else 0.0
    actors = {
        "ego": ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, x=list(cx - 60 + 4 * t),
                          y=[-1.75] * n, heading=[0.0] * n, speed=[4.0] * n,
                          states={"brake_lights": ["on" if v > seconds / 2 else "off" for v in t],
                                  "gnss_x": list(cx - 60 + 4 * t + np.sin(t)), "gnss_y": list(-1.75 + np.cos(t))}),
        "ambulance1": ActorTrack(asset="ambulance", x=list(cx - 90 + 7 * t), y=[-1.75] * n,
                                 states={"siren": ["on"] * n}),
        "car1": ActorTrack(asset="suv", x=list(cx + 60 - 5 * t), y=[1.75] * n, heading=[np.pi] * n),
        "adult1": ActorTrack(asset="adult", x=[cx - 20.0] * n, y=list(-8 + 0.8 * t)),
        "light1": ActorTrack(asset="traffic_light", kind="object", x=[cx - 14.0] * n, y=[-6.0] * n,
                             states={"light_state": ["red" if v < seconds / 2 else "green" for v in t]}),
    }
    trace = Trace(dt=dt, times=list(t), actors=actors, meta={"map": map_name, "map_path": str(map_path)})
    scenario = Scenario(id=f"bench-{map_name}", domain="driving",
                        behavior=Behavior(text="the ego-vehicle slows down", domain="driving"),
                        causal_graph=["x"], narrative="benchmark",
                        entities=[Entity(name=k, asset=a.asset) for k, a in actors.items()], fsm=FSM())
    verdict = Verdict(feasible=True, status="verified", reason="benchmark",
                      stages=[StageResult(index=k + 1, conditions=[f"ego: s{k}"], reached_at=seconds * k / 4)
                              for k in range(4)])
    return scenario, trace, verdict


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["REGEN_CACHE_DIR"] = str(Path(tmp) / "cache")
        from regen.contract import ANIMATION, KEYFRAMES
        from regen.driving.interop.openscenario import export_openscenario, validate_xosc
        from regen.driving.render.scenario import render_scenario
        from regen.driving.world.maps import ensure_map

        for map_name in ("straight", "four_way"):
            path = ensure_map(map_name)
            for seconds in (10.0, 30.0):
                scenario, trace, verdict = _run(map_name, path, seconds)
                t0 = time.perf_counter()
                out = render_scenario(scenario, trace, verdict, Path(tmp) / f"{map_name}-{seconds:.0f}")
                t1 = time.perf_counter()
                files = export_openscenario(scenario, trace, Path(tmp) / f"{map_name}-{seconds:.0f}")
                t2 = time.perf_counter()
                valid = not validate_xosc(files["xosc"])
                from PIL import Image

                frames = Image.open(out[ANIMATION]).n_frames
                print(f"{map_name:9s} {seconds:4.0f} s sim ({trace.steps} steps): render {t1 - t0:5.2f} s "
                      f"({frames} frames, {1000 * (t1 - t0) / frames:4.1f} ms/frame incl. map), "
                      f"GIF {out[ANIMATION].stat().st_size / 1e6:4.2f} MB, strip "
                      f"{out[KEYFRAMES].stat().st_size / 1e3:4.0f} kB; export {t2 - t1:5.3f} s, "
                      f"schema-valid {valid}")


if __name__ == "__main__":
    main()
