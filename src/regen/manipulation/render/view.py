"""Pictures of a manipulation run: a labeled image strip (PNG) and a GIF (TinyRenderer).

The trace is replayed into a freshly built scene (robot joint angles, furniture joints, object
positions), so rendering needs no live simulation. Labels are drawn with Pillow at each object's
projected position; the files are written by the shared media writer (:mod:`regen.media`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from regen import media
from regen.contract import ANIMATION, KEYFRAMES
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.manipulation.simulation.layout import ARM_JOINTS, FINGER_JOINTS
from regen.manipulation.simulation.run import layout_from_scenario
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.setting import ManipulationWorld

WIDTH, HEIGHT = 320, 240  # [px]
ANIMATION_FILE = "run.gif"
KEYFRAMES_FILE = "strip.png"
GIF_FRAME_MS = 150  # display time of each GIF frame [ms]
HEADER_H = 28  # band above the strip for the narrative and the verdict [px]
CAMERA = {"target": (0.6, 0.15, 0.3), "distance": 2.6, "yaw": -62.0, "pitch": -48.0}  # [m], [deg]
FIT = 1.1  # camera distance per metre of the scene's larger horizontal extent


def camera(p, client: int, steep: bool = False,
           extent: tuple[tuple[float, ...], tuple[float, ...]] | None = None) -> tuple[list[float], list[float]]:
    """The (view, projection) matrices of the run's camera; ``steep`` looks down over a wall,
    ``extent`` (lo, hi) [m] moves and widens it to keep that box in view."""
    # behind a wall (door, window) objects are only visible from a steep camera
    pitch = -68.0 if steep else CAMERA["pitch"]
    target, distance = CAMERA["target"], CAMERA["distance"]
    if extent is not None:  # every body in view: a person outside the door as well as the robot
        lo, hi = extent
        target = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, CAMERA["target"][2])
        distance = max(distance, FIT * max(hi[0] - lo[0], hi[1] - lo[1]))
    view = p.computeViewMatrixFromYawPitchRoll(target, distance, CAMERA["yaw"],
                                               pitch, 0, 2, physicsClientId=client)
    proj = p.computeProjectionMatrixFOV(55, WIDTH / HEIGHT, 0.05, 10.0, physicsClientId=client)
    return view, proj


def _extent(scene: Scene) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The horizontal box around the robot, the objects and the furniture (walls left out: they
    span the room)."""
    boxes = [scene.aabb(n) for n, b in scene.bodies.items() if not (b.spec is not None and b.spec.wall)]
    lo = tuple(min(bx.lo[k] for bx in boxes) for k in range(3))
    hi = tuple(max(bx.hi[k] for bx in boxes) for k in range(3))
    return lo, hi


def project(point: tuple[float, float, float], view: list[float], proj: list[float]) -> tuple[int, int] | None:
    """The pixel a world point [m] falls on, or None when it is behind the camera."""
    v = np.asarray(view).reshape(4, 4).T
    pr = np.asarray(proj).reshape(4, 4).T
    clip = pr @ v @ np.array([*point, 1.0])
    if clip[3] <= 0:
        return None
    ndc = clip[:3] / clip[3]
    return int((ndc[0] + 1) / 2 * WIDTH), int((1 - ndc[1]) / 2 * HEIGHT)


def _pose_at(scene: Scene, trace: Trace, i: int, offsets: dict[str, np.ndarray]) -> None:
    p, c = scene.p, scene.client
    for name, track in trace.actors.items():
        if name not in scene.bodies:
            continue
        b = scene.bodies[name]
        if b.is_robot:
            for k, j in enumerate((*ARM_JOINTS, *FINGER_JOINTS)):
                seq = track.states.get(f"q{k}")
                if seq:
                    p.resetJointState(b.id, j, float(seq[i]), physicsClientId=c)
            continue
        if b.kind == "furniture" and b.joint is not None and "joint_position" in track.states:
            p.resetJointState(b.id, b.joint, float(track.states["joint_position"][i]), physicsClientId=c)
        if name in offsets:
            pos, orn = p.getBasePositionAndOrientation(b.id, physicsClientId=c)
            centre = np.array([track.x[i], track.y[i], track.z[i]])
            p.resetBasePositionAndOrientation(b.id, (centre + offsets[name]).tolist(), orn,
                                              physicsClientId=c)


def _label_text(scenario: Scenario, name: str) -> str:
    e = scenario.entity(name)
    bits = [f"power {e.properties['power']}"] if e.properties.get("power") else []
    if e.properties.get("location"):
        bits.append(e.properties["location"].replace("_", " "))
    return f"{name} ({'; '.join(bits)})" if bits else name


def free_row(placed: list[tuple[float, float, float, float]], x0: float, y0: float, w: float,
             h: float = 11) -> float:
    """The top of a label ``w`` wide at ``x0`` nearest to ``y0`` that overlaps none of
    ``placed`` (two objects side by side on the table would print one label over the other)."""
    def free(y: float) -> bool:
        return all(x0 + w <= a or b <= x0 or y + h <= c or d <= y for a, c, b, d in placed)

    for step in range(12):
        for y in (y0 - step * (h + 1), y0 + step * (h + 1)):
            if 0 <= y <= HEIGHT - 14 - h and free(y):
                return y
    return y0


def render_frames(scenario: Scenario, trace: Trace, indices: list[int]) -> list[Image.Image]:
    """Images of the trace at the given sample indices, with object labels."""
    layout, _ = layout_from_scenario(scenario)
    lamp = ManipulationWorld.of(scenario).behavior == "turn_on_lamp"
    frames: list[Image.Image] = []
    with Scene(layout) as scene:
        p, c = scene.p, scene.client
        offsets: dict[str, np.ndarray] = {}
        for name, b in scene.bodies.items():
            if b.kind == "object" or (b.spec is not None and b.spec.dynamic):
                pos, _ = p.getBasePositionAndOrientation(b.id, physicsClientId=c)
                box = scene.aabb(name, -1 if b.kind == "furniture" else None)
                centre = (np.asarray(box.lo) + np.asarray(box.hi)) / 2
                offsets[name] = np.asarray(pos) - centre
        view, proj = camera(p, c, any(b.spec is not None and b.spec.wall for b in scene.bodies.values()),
                             _extent(scene))
        for i in indices:
            _pose_at(scene, trace, i, offsets)
            if lamp:
                on = any(v == "on" for a in trace.actors.values() for v in [a.states.get("power", [None] * (i + 1))[i]])
                for b in scene.bodies.values():
                    if b.asset == "lamp":
                        p.changeVisualShape(b.id, -1, rgbaColor=(1, 0.9, 0.3, 1) if on else (0.2, 0.2, 0.22, 1),
                                            physicsClientId=c)
            _, _, rgba, _, _ = p.getCameraImage(WIDTH, HEIGHT, view, proj, renderer=p.ER_TINY_RENDERER,
                                                physicsClientId=c)
            img = Image.fromarray(np.asarray(rgba, dtype=np.uint8).reshape(HEIGHT, WIDTH, 4)[:, :, :3])
            draw = ImageDraw.Draw(img)
            placed: list[tuple[float, float, float, float]] = []
            for name, track in trace.actors.items():
                if name == "robot" or name not in scene.bodies:
                    continue
                top = (track.x[i], track.y[i], track.z[i] + track.height / 2 + 0.05)
                xy = project(top, view, proj)
                if xy is None:
                    continue
                text = _label_text(scenario, name)
                w = draw.textlength(text)
                x0 = max(0, min(WIDTH - w - 4, xy[0] - w / 2))
                y0 = free_row(placed, x0, max(0, xy[1] - 12), w + 4)
                placed.append((x0, y0, x0 + w + 4, y0 + 11))
                draw.rectangle((x0, y0, x0 + w + 4, y0 + 11), fill=(255, 255, 255))
                draw.text((x0 + 2, y0), text, fill=(0, 0, 0))
            draw.rectangle((2, HEIGHT - 13, 62, HEIGHT - 1), fill=(0, 0, 0))
            draw.text((4, HEIGHT - 12), f"t = {trace.times[i]:.1f} s", fill=(255, 255, 255))
            frames.append(img)
    return frames


def render_run(scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path,
               *, strip_frames: int = 4, gif_frames: int = 16) -> dict[str, Path]:
    """Write ``strip.png`` (``strip_frames`` frames from start to end, below the narrative and
    the verdict) and ``run.gif`` (``gif_frames`` frames spread over the run, 150 ms each) at
    320x240 px a frame. Returns ``{ANIMATION: gif path, KEYFRAMES: png path}`` (roles of
    :mod:`regen.domains`)."""
    out_dir = Path(out_dir)
    animation = media.AnimationSettings(max_frames=gif_frames, fps=None, frame_ms=GIF_FRAME_MS)
    strip_idx = media.spread(trace.steps, strip_frames)
    gif_idx = media.animation_steps(trace.times, animation)
    wanted = sorted(set(strip_idx) | set(gif_idx))
    by_idx = dict(zip(wanted, render_frames(scenario, trace, wanted), strict=True))
    strip = media.strip([by_idx[i] for i in strip_idx], top_px=HEADER_H)
    d = ImageDraw.Draw(strip)
    d.text((4, 2), scenario.narrative[:200], fill=(0, 0, 0))
    d.text((4, 14), f"verdict: {verdict.status} - {verdict.reason[:150]}",
           fill=(0, 120, 0) if verdict.feasible else (170, 0, 0))
    png = media.write_png(out_dir / KEYFRAMES_FILE, strip)
    gif = media.write_gif(out_dir / ANIMATION_FILE, [by_idx[i] for i in gif_idx],
                          media.frame_ms(trace.times, gif_idx, animation))
    return {ANIMATION: gif, KEYFRAMES: png}


__all__ = ["ANIMATION_FILE", "CAMERA", "GIF_FRAME_MS", "HEIGHT", "KEYFRAMES_FILE", "WIDTH", "camera", "free_row",
           "project", "render_frames", "render_run"]
