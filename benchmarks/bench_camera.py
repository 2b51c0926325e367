"""How fast the ego's forward camera renders (Panda3D, software display, one CPU core).

Run: ``python benchmarks/bench_camera.py [FRAMES]`` (default 200) from the checkout. It renders
the demo run's scenario 02 (``runs/demo/scenarios/02-*``) when it is there, else a built-in
trace on the generated straight map, and prints: the map read (Scenic), the first call (engine
start, map triangulated, actors built, one frame), a scene build with the engine warm, and
frames per second and milliseconds per frame at 640x360.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SIZE = (640, 360)  # [px]


def _demo():
    """(name, scenario, trace, map path) of the demo run's scenario 02, or None."""
    from regen.core.scenario import Scenario
    from regen.core.trace import Trace

    found = sorted((ROOT / "runs" / "demo" / "scenarios").glob("02-*/trace.json"))
    if not found:
        return None
    folder = found[0].parent
    raw = json.loads((folder / "scenario.json").read_text())
    scenario = Scenario.model_validate(raw.get("scenario", raw))
    trace = Trace.model_validate_json((folder / "trace.json").read_text())
    maps = sorted(folder.glob("*.xodr"))
    return folder.name, scenario, trace, (maps[0] if maps else None)


def _built_in():
    """A 16 s trace on the straight map: the ego behind a braking car, a pedestrian crossing,
    a traffic light turning red, an ambulance with its siren on coming the other way."""
    from regen.core.behavior import Behavior
    from regen.core.scenario import FSM, Entity, Scenario
    from regen.core.trace import ActorTrack, Trace
    from regen.driving.world.maps import ensure_map

    dt, seconds = 0.1, 16.0
    t = np.round(np.arange(0, seconds + 1e-9, dt), 6)
    n = len(t)
    late = t > seconds / 2
    actors = {
        "ego": ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, height=1.5,
                          x=list(-60 + 5 * t), y=[-1.75] * n, heading=[0.0] * n),
        "car1": ActorTrack(asset="sedan", length=4.6, width=1.9, height=1.5, x=list(-40 + 4.5 * t),
                           y=[-1.75] * n, heading=[0.0] * n,
                           states={"brake_lights": ["on" if v else "off" for v in late]}),
        "adult1": ActorTrack(asset="adult", length=0.5, width=0.5, height=1.8, x=[30.0] * n,
                             y=list(-8 + 0.8 * t), heading=[np.pi / 2] * n),
        "light1": ActorTrack(asset="traffic_light", kind="object", height=4.0, x=[32.0] * n, y=[-6.0] * n,
                             states={"light_state": ["red" if v else "green" for v in late]}),
        "ambulance1": ActorTrack(asset="ambulance", length=6.4, width=2.4, height=2.9,
                                 x=list(80 - 8 * t), y=[1.75] * n, heading=[np.pi] * n,
                                 states={"siren": ["on"] * n}),
    }
    trace = Trace(dt=dt, times=list(t), actors=actors, meta={"map": "straight"})
    scenario = Scenario(id="bench-camera", domain="driving",
                        behavior=Behavior(text="the ego-vehicle stops", domain="driving"),
                        causal_graph=["cause", "the ego-vehicle stops"], narrative="bench",
                        entities=[Entity(name=k, asset=a.asset, kind=a.kind) for k, a in actors.items()],
                        fsm=FSM(states=[], stages=[]))
    return "built-in (straight map)", scenario, trace, ensure_map("straight")


def main(frames: int = 200) -> None:
    from regen.driving.render.camera import camera_available, camera_frames
    from regen.driving.render.roads import read_map_layers

    if not camera_available():
        sys.exit("panda3d is not installed: pip install 'regen-sim[camera]'")
    name, scenario, trace, map_path = _demo() or _built_in()
    print(f"scenario: {name}; {trace.steps} steps of {trace.dt} s, {len(trace.actors)} actors, map {map_path}")

    t0 = time.perf_counter()
    layers = read_map_layers(map_path) if map_path is not None else None
    print(f"map read (Scenic): {1000 * (time.perf_counter() - t0):.0f} ms"
          f"{'' if layers is not None else ' (no map: plain ground)'}")

    t0 = time.perf_counter()
    camera_frames(scenario, trace, [0.0], size=SIZE, map_path=map_path)
    cold = time.perf_counter() - t0
    print(f"first call (engine start, map triangulated, scene built, 1 frame): {1000 * cold:.0f} ms")

    builds = []
    for _ in range(5):
        t0 = time.perf_counter()
        camera_frames(scenario, trace, [0.0], size=SIZE, map_path=map_path)
        builds.append(time.perf_counter() - t0)

    times = np.linspace(trace.times[0], trace.times[-1], frames)
    t0 = time.perf_counter()
    images = camera_frames(scenario, trace, times, size=SIZE, map_path=map_path)
    total = time.perf_counter() - t0
    per_frame = (total - min(builds)) / frames  # the scene is built once per call
    build = max(min(builds) - per_frame, 0.0)
    print(f"scene build, engine warm (actors; map kept): {1000 * build:.1f} ms")
    print(f"{frames} frames at {SIZE[0]}x{SIZE[1]}: {total:.2f} s in one call -> "
          f"{frames / total:.0f} frames/s, {1000 * per_frame:.2f} ms/frame")
    assert len(images) == frames and images[0].size == SIZE


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
