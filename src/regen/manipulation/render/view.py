"""Pictures of a manipulation run: a GIF and a strip of key frames (PNG), 640x480 px a frame.

The trace is replayed into a freshly built scene (robot joint angles, furniture joints, object
positions), so rendering needs no live simulation. The camera (PyBullet's TinyRenderer) frames
every body of the scene; in a scene with a wall (a door, a window) it looks along the wall from
the robot's side, so what stands behind it (the person who wants to come in: often the cause)
is in the picture too. Labels are drawn with Pillow at each object's projected position, the
cause's marked with a star; under the picture the caption band every domain's frames share
(:func:`regen.media.draw_caption`: the time, the verdict, one box per FSM stage). The strip
shows the start, each FSM stage reached and the end, as the driving strip does; the files are
written by the shared media writer (:mod:`regen.media`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
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

WIDTH, HEIGHT = 640, 480  # [px] a frame
VIEW_H = HEIGHT - media.CAPTION_H  # [px] the camera's picture, above the caption band
ANIMATION_FILE = "run.gif"
KEYFRAMES_FILE = "strip.png"
GIF_FRAMES = 16  # frames of the GIF (the key frames among them); each costs ~0.1 s to render
GIF_FRAME_MS = 250  # display time of each GIF frame [ms] (the last one is held longer)
KEYFRAME_GAP = 4  # [px] between tiles of the strip
FOV = 55.0  # [deg] vertical field of view
# TinyRenderer's time grows with the pixels it shades: the camera renders at this fraction of the
# picture and the image is scaled up (smoothly, which also hides its jagged edges); labels and
# captions are drawn at full size
RENDER_SCALE = 0.8
CAMERA = {"target": (0.6, 0.15, 0.3), "distance": 2.6, "yaw": -62.0, "pitch": -48.0}  # [m], [deg]
STEEP_PITCH = -68.0  # [deg] over a wall, when no wall geometry is given
WALL_PITCH = -65.0  # [deg] looking along a wall
WALL_TURN = 10.0  # [deg] the view along a wall is turned this far toward the robot's side
YAWS = (-62.0, -100.0, -20.0, -140.0, 20.0)  # [deg] views tried around a scene without a wall
SCOUT_W = 128  # [px] width of the small renders that compare views
MARGIN = 0.06  # of the picture kept free around the bodies (labels sit above them)
MAX_HEIGHT = 1.8  # [m] bodies are framed up to this height (a person's head)
CAUSE_LABEL = (255, 214, 102)  # background of the cause's label (RGB)
HOLD_S = 1.0  # [s] of a failed test's episode shown after the failure

Box = tuple[tuple[float, ...], tuple[float, ...]]  # (lo, hi) [m]


def _matrices(p, client: int, target, distance: float, yaw: float, pitch: float):
    view = p.computeViewMatrixFromYawPitchRoll(target, distance, yaw, pitch, 0, 2, physicsClientId=client)
    proj = p.computeProjectionMatrixFOV(FOV, WIDTH / VIEW_H, 0.05, 20.0, physicsClientId=client)
    return view, proj


def _corners(box: Box) -> list[tuple[float, float, float]]:
    lo, hi = box
    top = min(hi[2], max(lo[2], MAX_HEIGHT))
    return [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], top)]


def _fits(points, view, proj) -> bool:
    mx, my = MARGIN * WIDTH, MARGIN * VIEW_H
    for pt in points:
        xy = project(pt, view, proj)
        if xy is None or not (mx <= xy[0] <= WIDTH - mx and 2 * my <= xy[1] <= VIEW_H - my):
            return False
    return True


def along_wall(wall: Box, robot: tuple[float, float], centre: tuple[float, float],
               end: int | None = None) -> float:
    """The camera yaw [deg] that looks along ``wall`` (its longer horizontal side) from one end
    (``end`` -1 or 1 along that side; None: the end nearer the robot than ``centre`` is), turned
    :data:`WALL_TURN` toward the robot's side of it: the robot's side and the far side are both
    in view, and the wall is a thin band between them."""
    lo, hi = wall
    axis = 0 if hi[0] - lo[0] >= hi[1] - lo[1] else 1
    other = 1 - axis
    mid = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2)
    u = [0.0, 0.0]
    u[axis] = float(end) if end is not None else (-1.0 if robot[axis] <= centre[axis] else 1.0)
    n = [0.0, 0.0]
    n[other] = -1.0 if robot[other] < mid[other] else 1.0
    turn = math.radians(WALL_TURN)
    ex, ey = (math.cos(turn) * u[k] + math.sin(turn) * n[k] for k in (0, 1))
    return math.degrees(math.atan2(ex, -ey))  # PyBullet puts the eye at (sin yaw, -cos yaw)


def camera(p, client: int, steep: bool = False, extent: Box | None = None,
           wall: Box | None = None, robot: tuple[float, float] = (0.0, 0.0),
           bodies: Sequence[Box] = (), *, yaw: float | None = None,
           end: int | None = None) -> tuple[list[float], list[float]]:
    """The (view, projection) matrices of the run's camera; ``steep`` looks down over a wall,
    ``wall`` (lo, hi) [m] looks along it instead (:func:`along_wall` from ``end``), ``yaw``
    [deg] turns it; ``extent`` (lo, hi) [m] moves the camera to the box and back until all of it
    (or of the boxes ``bodies`` inside it, a closer fit) is in the picture, centred."""
    pitch = STEEP_PITCH if steep else CAMERA["pitch"]
    yaw = CAMERA["yaw"] if yaw is None else yaw
    target, distance = CAMERA["target"], CAMERA["distance"]
    if extent is None:
        return _matrices(p, client, target, distance, yaw, pitch)
    lo, hi = extent
    centre = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2)
    if wall is not None:
        yaw, pitch = along_wall(wall, robot, centre, end), WALL_PITCH
    points = [c for b in (bodies or [extent]) for c in _corners(b)]
    target = np.array([centre[0], centre[1], 0.35 * min(hi[2], MAX_HEIGHT)])
    for _ in range(3):  # fit, then move the target so the bodies sit in the middle, fit again
        view, proj = _fit(p, client, tuple(target), yaw, pitch, points)
        px = np.array([xy for xy in (project(pt, view, proj) for pt in points) if xy is not None], float)
        if not len(px):
            break
        dx = (px[:, 0].min() + px[:, 0].max()) / 2 - WIDTH / 2
        dy = (px[:, 1].min() + px[:, 1].max()) / 2 - VIEW_H / 2 - MARGIN * VIEW_H / 2
        if abs(dx) < 4 and abs(dy) < 4:
            break
        v = np.asarray(view).reshape(4, 4)  # column-major: rows of the rotation are its columns
        right, up = v[:3, 0], v[:3, 1]
        eye_d = float(np.linalg.norm(-np.asarray(v)[3, :3] @ np.linalg.inv(v[:3, :3]) - target))
        m_per_px = 2 * eye_d * math.tan(math.radians(FOV) / 2) / VIEW_H
        target = target + m_per_px * (dx * right - dy * up)
    return view, proj


def _fit(p, client: int, target, yaw: float, pitch: float, points) -> tuple[list[float], list[float]]:
    """The closest camera at ``target`` looking at (yaw, pitch) that has all ``points`` in the
    picture (the farthest tried when none does)."""
    for d in np.arange(1.0, 8.0, 0.05):
        view, proj = _matrices(p, client, target, float(d), yaw, pitch)
        if _fits(points, view, proj):
            return view, proj
    return view, proj


def _boxes(scene: Scene) -> tuple[Box, Box | None, list[Box]]:
    """The box around the robot, the objects and the furniture (a wall only around its opening:
    it spans the room), the first wall's box (None without one) and each body's box."""
    boxes, wall = [], None
    for n, b in scene.bodies.items():
        bx = scene.aabb(n)
        lo, hi = list(bx.lo), list(bx.hi)
        if b.spec is not None and b.spec.wall:
            axis = 0 if hi[0] - lo[0] >= hi[1] - lo[1] else 1
            mid = (lo[axis] + hi[axis]) / 2
            if wall is None:
                wall = (tuple(lo), tuple(hi))
            lo[axis], hi[axis] = mid - 0.4, mid + 0.4
        boxes.append((tuple(lo), tuple(hi)))
    extent = (tuple(min(b[0][k] for b in boxes) for k in range(3)),
              tuple(max(b[1][k] for b in boxes) for k in range(3)))
    return extent, wall, boxes


def _visibility(scene: Scene, view, proj) -> float:
    """How well a camera shows the scene: the sum over its bodies of log(1 + the pixels it
    shows of each) in a small segmentation render, so a body hidden behind another (a tall
    person in front of the robot) costs more than a few pixels less of a big one."""
    p, c = scene.p, scene.client
    w, h = SCOUT_W, round(SCOUT_W * VIEW_H / WIDTH)
    seg = np.asarray(p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER,
                                      physicsClientId=c)[4]).reshape(-1)
    ids, counts = np.unique(seg[seg >= 0] & 0xFFFFFF, return_counts=True)
    seen = dict(zip(ids.tolist(), counts.tolist(), strict=True))
    return float(sum(math.log1p(seen.get(b.id, 0)) for b in scene.bodies.values()))


def scene_camera(scene: Scene) -> tuple[list[float], list[float]]:
    """The camera of a scene's pictures (:func:`camera` fitted to its bodies): along its wall
    from either end, or from one of :data:`YAWS` around the robot, whichever shows the most of
    every body (:func:`_visibility`) in the scene as built (the run's start)."""
    p, c = scene.p, scene.client
    extent, wall, boxes = _boxes(scene)
    robot = next((scene.aabb(n) for n, b in scene.bodies.items() if b.is_robot), None)
    at = ((robot.lo[0] + robot.hi[0]) / 2, (robot.lo[1] + robot.hi[1]) / 2) if robot else (0.0, 0.0)
    if wall is not None:
        centre = ((extent[0][0] + extent[1][0]) / 2, (extent[0][1] + extent[1][1]) / 2)
        axis = 0 if wall[1][0] - wall[0][0] >= wall[1][1] - wall[0][1] else 1
        first = -1 if at[axis] <= centre[axis] else 1
        options = [{"end": first}, {"end": -first}]
    else:
        options = [{"yaw": y} for y in YAWS]
    best, best_score = None, -1.0
    for o in options:
        cam = camera(p, c, wall is not None, extent, wall, at, boxes, **o)
        score = _visibility(scene, *cam)
        if score > best_score + 0.5:  # the first (the usual view) unless another is clearly better
            best, best_score = cam, score
    return best


def project(point: tuple[float, float, float], view: list[float], proj: list[float]) -> tuple[int, int] | None:
    """The pixel of the camera's picture a world point [m] falls on, or None when it is behind
    the camera."""
    v = np.asarray(view).reshape(4, 4).T
    pr = np.asarray(proj).reshape(4, 4).T
    clip = pr @ v @ np.array([*point, 1.0])
    if clip[3] <= 0:
        return None
    ndc = clip[:3] / clip[3]
    return int((ndc[0] + 1) / 2 * WIDTH), int((1 - ndc[1]) / 2 * VIEW_H)


def body_offsets(scene: Scene) -> dict[str, np.ndarray]:
    """Base position minus AABB centre [m] of each body that moves (objects, dynamic furniture):
    the trace records centres, PyBullet places bases."""
    p, c = scene.p, scene.client
    offsets: dict[str, np.ndarray] = {}
    for name, b in scene.bodies.items():
        if b.kind == "object" or (b.spec is not None and b.spec.dynamic):
            pos, _ = p.getBasePositionAndOrientation(b.id, physicsClientId=c)
            box = scene.aabb(name, -1 if b.kind == "furniture" else None)
            centre = (np.asarray(box.lo) + np.asarray(box.hi)) / 2
            offsets[name] = np.asarray(pos) - centre
    return offsets


def pose_at(scene: Scene, trace: Trace, i: int, offsets: dict[str, np.ndarray]) -> None:
    """Put the scene's bodies where the trace has them at sample ``i`` (robot joints, furniture
    joints, moving bodies by :func:`body_offsets`)."""
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


def _causes(scenario: Scenario) -> set[str]:
    """The entities whose FSM states show the cause (their labels get a star)."""
    robot = {e.name for e in scenario.entities if e.is_robot}
    return {s.actor for s in scenario.fsm.states if s.cause} - robot


def free_row(placed: list[tuple[float, float, float, float]], x0: float, y0: float, w: float,
             h: float = 15) -> float:
    """The top of a label ``w`` wide at ``x0`` nearest to ``y0`` that overlaps none of
    ``placed`` (two objects side by side on the table would print one label over the other)."""
    def free(y: float) -> bool:
        return all(x0 + w <= a or b <= x0 or y + h <= c or d <= y for a, c, b, d in placed)

    for step in range(12):
        for y in (y0 - step * (h + 1), y0 + step * (h + 1)):
            if 0 <= y <= VIEW_H - h and free(y):
                return y
    return y0


def stage_bar(scenario: Scenario, trace: Trace, verdict: Verdict) -> media.StageBar:
    """What the caption band tells: the verdict's stages, or the FSM's when it has none."""
    stages = [(s.index, s.reached_at, ", ".join(s.conditions)) for s in verdict.stages]
    if not stages:
        stages = [(k + 1, None, ", ".join(f"{c.actor}: {c.state}" for c in st.conditions))
                  for k, st in enumerate(scenario.fsm.stages)]
    return media.StageBar(stages, verdict.status, verdict.first_unmet_stage, float(trace.times[-1]))


def _banner(img: Image.Image, text: str) -> None:
    """A red band across the top with ``text`` in white (a failed test's cause)."""
    draw = ImageDraw.Draw(img)
    font = media.text_font(12, bold=True)
    draw.rectangle((0, 0, WIDTH, 19), fill=media.STAGE_FAILED)
    draw.text((6, 2), media.fit_text(draw, text, font, WIDTH - 12), fill=(255, 255, 255), font=font)


def _labels(img: Image.Image, scenario: Scenario, trace: Trace, i: int, names: set[str],
            causes: set[str], view, proj) -> None:
    """A label above each object of ``names`` in the picture at step ``i`` (the cause's starred
    and yellow), moved up or down off the labels already drawn."""
    draw = ImageDraw.Draw(img)
    font = media.text_font(11)
    placed: list[tuple[float, float, float, float]] = []
    for name, track in trace.actors.items():
        if name == "robot" or name not in names:
            continue
        top = (track.x[i], track.y[i], track.z[i] + track.height / 2 + 0.05)
        xy = project(top, view, proj)
        if xy is None or not (0 <= xy[0] < WIDTH and 0 <= xy[1] < VIEW_H):
            continue  # out of the picture: no label at its edge for it
        text = ("\u2605 " if name in causes else "") + _label_text(scenario, name)
        w = draw.textlength(text, font=font) + 6
        x0 = max(0, min(WIDTH - w - 1, xy[0] - w / 2))
        y0 = free_row(placed, x0, max(0, xy[1] - 16), w)
        placed.append((x0, y0, x0 + w, y0 + 15))
        draw.rectangle((x0, y0, x0 + w, y0 + 15), fill=CAUSE_LABEL if name in causes else (255, 255, 255),
                       outline=(60, 60, 60))
        draw.text((x0 + 3, y0 + 1), text, fill=(0, 0, 0), font=font)


def _shot(scene: Scene, view, proj) -> Image.Image:
    """The camera's picture, :data:`RENDER_SCALE` of its size rendered and scaled up."""
    p, c = scene.p, scene.client
    rw, rh = round(WIDTH * RENDER_SCALE), round(VIEW_H * RENDER_SCALE)
    _, _, rgba, _, _ = p.getCameraImage(rw, rh, view, proj, renderer=p.ER_TINY_RENDERER,
                                        flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=c)
    shot = Image.fromarray(np.asarray(rgba, dtype=np.uint8).reshape(rh, rw, 4)[:, :, :3])
    return shot if (rw, rh) == (WIDTH, VIEW_H) else shot.resize((WIDTH, VIEW_H), Image.Resampling.BICUBIC)


def light_lamps(scene: Scene, trace: Trace, i: int) -> None:
    """Lamps yellow while a ``power`` state is on at step ``i``, dark grey otherwise."""
    on = any(seq[i] == "on" for a in trace.actors.values() if (seq := a.states.get("power")) and len(seq) > i)
    for b in scene.bodies.values():
        if b.asset == "lamp":
            scene.p.changeVisualShape(b.id, -1, rgbaColor=(1, 0.9, 0.3, 1) if on else (0.2, 0.2, 0.22, 1),
                                      physicsClientId=scene.client)


def render_frames(scenario: Scenario, trace: Trace, indices: Sequence[int],
                  bar: media.StageBar | None = None, banner: str | None = None) -> list[Image.Image]:
    """640x480 px frames of the trace at the given sample indices: the camera's picture with
    object labels, and below it the caption band of ``bar`` (a bare time stamp without one);
    ``banner`` writes a failed test's cause across the top."""
    layout, _ = layout_from_scenario(scenario)
    lamp = ManipulationWorld.of(scenario).behavior == "turn_on_lamp"
    causes = _causes(scenario)
    frames: list[Image.Image] = []
    with Scene(layout) as scene:
        offsets = body_offsets(scene)
        if indices:  # framed where the run puts the bodies (a test's variant moves them)
            pose_at(scene, trace, indices[0], offsets)
        view, proj = scene_camera(scene)
        for i in indices:
            pose_at(scene, trace, i, offsets)
            if lamp:
                light_lamps(scene, trace, i)
            img = Image.new("RGB", (WIDTH, HEIGHT), media.CAPTION_BG)
            img.paste(_shot(scene, view, proj))
            _labels(img, scenario, trace, i, set(scene.bodies), causes, view, proj)
            t = float(trace.times[i])
            if bar is not None:
                media.draw_caption(img, VIEW_H, bar, t)
            else:
                ImageDraw.Draw(img).text((8, VIEW_H + 6), f"t = {t:5.1f} s", fill=media.CAPTION_FG,
                                         font=media.text_font(13, True))
            if banner:
                _banner(img, banner)
            frames.append(img)
    return frames


def _palette(frames: list[Image.Image]) -> Image.Image:
    """One palette for all frames, from the first, the middle and the last (a lamp that turns
    on, a door that opens)."""
    return media.palette_of([frames[0], frames[len(frames) // 2], frames[-1]])


def gif_steps(n: int, keys: Sequence[int], count: int = GIF_FRAMES) -> list[int]:
    """``count`` sample indices spread over ``0 .. n-1``, each of ``keys`` in place of the
    spread index nearest to it (so the key frames cost no extra rendering)."""
    steps = media.spread(n, count)
    for k in keys:
        if k in steps:
            continue
        j = min(range(len(steps)), key=lambda m: abs(steps[m] - k))
        steps[j] = k
    return sorted(set(steps))


def render_run(scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path,
               *, strip_frames: int = 6, gif_frames: int = GIF_FRAMES) -> dict[str, Path]:
    """Write ``strip.png`` (at most ``strip_frames`` key frames: the start, each FSM stage
    reached and the end, at least 4, side by side 4 px apart, each titled) and ``run.gif``
    (``gif_frames`` frames spread over the run, the key frames among them,
    :data:`GIF_FRAME_MS` each, the last held :data:`regen.media.HOLD_MS`), 640x480 px a frame
    with the verdict's stage bar. Returns ``{ANIMATION: gif path, KEYFRAMES: png path}`` (roles
    of :mod:`regen.domains`)."""
    out_dir = Path(out_dir)
    bar = stage_bar(scenario, trace, verdict)
    times = np.asarray(trace.times, float)
    picks = media.keyframe_steps(times, bar.stages, max(1, strip_frames))
    gif_idx = gif_steps(trace.steps, [i for i, _ in picks], gif_frames)
    by_idx = dict(zip(gif_idx, render_frames(scenario, trace, gif_idx, bar), strict=True))
    tiles = []
    for i, title in picks:
        tile = by_idx[i].copy()
        media.draw_title(tile, title)
        tiles.append(tile)
    png = media.write_png(out_dir / KEYFRAMES_FILE, media.strip(tiles, gap_px=KEYFRAME_GAP))
    frames = [by_idx[i] for i in gif_idx]
    gif = media.write_gif(out_dir / ANIMATION_FILE, frames, media.held(len(frames), GIF_FRAME_MS),
                          palette=_palette(frames))
    return {ANIMATION: gif, KEYFRAMES: png}


def render_failure(scenario: Scenario, trace: Trace, out: Path, *,
                   stages: list[tuple[int, float | None, str]], status: str, banner: str,
                   until: float | None = None, frames: int = GIF_FRAMES) -> Path:
    """A failed test's episode as the GIF ``out``: ``frames`` frames spread from the start to
    :data:`HOLD_S` after the failure at ``until`` [s] (None: to the end), the last held
    :data:`regen.media.HOLD_MS`; the caption's stage bar shows the test's ``stages`` (index,
    reached_at [s], conditions) and ``status``, ``banner`` the failure across the top."""
    times = np.asarray(trace.times, float)
    last = media.steps_until(times, [], until + HOLD_S)[-1] if until is not None else len(times) - 1
    idx = media.spread(last + 1, frames)
    bar = media.StageBar(stages, status, None, float(times[-1]))
    images = render_frames(scenario, trace, idx, bar, banner=banner)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    return media.write_gif(out, images, media.held(len(images), GIF_FRAME_MS), palette=_palette(images))


__all__ = ["ANIMATION_FILE", "CAMERA", "GIF_FRAMES", "GIF_FRAME_MS", "HEIGHT", "KEYFRAMES_FILE", "VIEW_H",
           "WIDTH", "along_wall", "body_offsets", "camera", "free_row", "gif_steps", "light_lamps",
           "pose_at", "project", "render_failure", "render_frames", "render_run", "scene_camera",
           "stage_bar"]
