"""The robot-learning cameras: a fixed scene camera and a wrist camera on the Panda's hand.

Both render with PyBullet's TinyRenderer (``ER_TINY_RENDERER``: software, headless, the same
pixels for the same scene on every run) at :data:`SIZE`, from a trace replayed into a freshly
built scene (:func:`~regen.manipulation.render.view.pose_at`), so no live simulation is needed.

The scene camera stands still in the robot's frame (the robot's base is at the origin, facing
+x, in every manipulation scene): behind the robot's right shoulder, above it, looking at the
workspace in front of it, so every episode of a dataset sees the robot and the furniture from
the same place. The wrist camera rides on the hand (link ``EE_LINK``), a little behind the
fingertips and off to the side of the palm, looking along the gripper's approach axis, as a
wrist-mounted camera on a real Panda does; the fingers are in its picture.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.manipulation.render.view import body_offsets, light_lamps, pose_at
from regen.manipulation.simulation.layout import EE_LINK
from regen.manipulation.simulation.run import layout_from_scenario
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.setting import ManipulationWorld

SIZE = (128, 128)  # [px] width, height of both cameras' pictures
SCENE_EYE = (-0.75, -0.85, 1.35)  # [m] the scene camera, in the robot's frame
SCENE_TARGET = (0.45, 0.05, 0.35)  # [m] the point it looks at
SCENE_FOV = 60.0  # [deg] vertical field of view
WRIST_OFFSET = (0.06, 0.0, -0.11)  # [m] camera position in the hand frame (+z: approach axis)
WRIST_LOOK = 0.3  # [m] how far along the approach axis the wrist camera aims
WRIST_FOV = 75.0  # [deg]
NEAR, FAR = 0.02, 10.0  # [m] clipping planes
CAMERAS = ("scene", "wrist")


def _projection(p, client: int, fov: float) -> list[float]:
    w, h = SIZE
    return p.computeProjectionMatrixFOV(fov, w / h, NEAR, FAR, physicsClientId=client)


def scene_view(scene: Scene) -> tuple[list[float], list[float]]:
    """(view, projection) matrices of the fixed scene camera."""
    p, c = scene.p, scene.client
    view = p.computeViewMatrix(SCENE_EYE, SCENE_TARGET, (0, 0, 1), physicsClientId=c)
    return view, _projection(p, c, SCENE_FOV)


def wrist_view(scene: Scene) -> tuple[list[float], list[float]]:
    """(view, projection) matrices of the wrist camera where the hand is now."""
    p, c = scene.p, scene.client
    state = p.getLinkState(scene.robot, EE_LINK, computeForwardKinematics=True, physicsClientId=c)
    pos, orn = np.asarray(state[4]), state[5]
    rot = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
    eye = pos + rot @ np.asarray(WRIST_OFFSET)
    target = eye + rot[:, 2] * WRIST_LOOK
    view = p.computeViewMatrix(eye.tolist(), target.tolist(), rot[:, 0].tolist(), physicsClientId=c)
    return view, _projection(p, c, WRIST_FOV)


def shot(scene: Scene, view: list[float], proj: list[float]) -> np.ndarray:
    """The camera's RGB picture, (height, width, 3) uint8."""
    p, c = scene.p, scene.client
    w, h = SIZE
    _, _, rgba, _, _ = p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER,
                                        flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=c)
    return np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)[:, :, :3].copy()


def replay_cameras(scenario: Scenario, trace: Trace, indices: Sequence[int]) -> dict[str, list[np.ndarray]]:
    """Both cameras' pictures of the trace at the given sample indices:
    ``{"scene": [...], "wrist": [...]}``, each (height, width, 3) uint8 per index."""
    layout, _ = layout_from_scenario(scenario)
    lamp = ManipulationWorld.of(scenario).behavior == "turn_on_lamp"
    out: dict[str, list[np.ndarray]] = {name: [] for name in CAMERAS}
    with Scene(layout) as scene:
        offsets = body_offsets(scene)
        fixed = scene_view(scene)
        for i in indices:
            pose_at(scene, trace, i, offsets)
            if lamp:
                light_lamps(scene, trace, i)
            out["scene"].append(shot(scene, *fixed))
            out["wrist"].append(shot(scene, *wrist_view(scene)))
    return out


__all__ = ["CAMERAS", "SCENE_EYE", "SCENE_FOV", "SCENE_TARGET", "SIZE", "WRIST_FOV", "WRIST_OFFSET",
           "replay_cameras", "scene_view", "shot", "wrist_view"]
