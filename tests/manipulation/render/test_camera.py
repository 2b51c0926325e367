"""The robot-learning cameras: a fixed scene camera and a wrist camera, deterministic, each
showing what it should."""

from __future__ import annotations

import pytest

pybullet = pytest.importorskip("pybullet")

import numpy as np  # noqa: E402

from regen.manipulation.render.camera import SIZE, scene_view, shot, wrist_view  # noqa: E402


@pytest.fixture(scope="module")
def door_scene():
    from manipulation_chains import door_scenario

    from regen.manipulation.simulation.run import layout_from_scenario
    from regen.manipulation.simulation.scene import Scene

    sc = door_scenario({"child1": ("outside", "door1")}, ["child"])
    with Scene(layout_from_scenario(sc)[0]) as scene:
        yield scene


def _mask(scene, view, proj, name: str) -> np.ndarray:
    """Where body ``name`` is in the camera's picture (a segmentation render)."""
    w, h = SIZE
    seg = np.asarray(scene.p.getCameraImage(w, h, view, proj, renderer=scene.p.ER_TINY_RENDERER,
                                            physicsClientId=scene.client)[4]).reshape(h, w)
    return (seg >= 0) & ((seg & 0xFFFFFF) == scene.bodies[name].id)


def test_the_two_cameras_differ_and_render_the_same_pixels_twice(door_scene) -> None:
    views = {"scene": scene_view(door_scene), "wrist": wrist_view(door_scene)}
    a = {k: shot(door_scene, *v) for k, v in views.items()}
    b = {k: shot(door_scene, *v) for k, v in views.items()}
    for k in views:
        assert a[k].shape == (SIZE[1], SIZE[0], 3) and a[k].dtype == np.uint8
        assert np.array_equal(a[k], b[k]), k
    assert np.mean(a["scene"] != a["wrist"]) > 0.3


def test_the_scene_camera_shows_the_robot_and_the_door_where_expected(door_scene) -> None:
    view, proj = scene_view(door_scene)
    robot, door = _mask(door_scene, view, proj, "robot"), _mask(door_scene, view, proj, "door1")
    h, w = robot.shape
    assert robot.sum() > 0.02 * h * w and door.sum() > 0.05 * h * w
    rows, cols = np.nonzero(robot)
    # the robot stands in the lower middle, the door (in its wall) fills the upper part
    assert h * 0.3 < rows.mean() < h * 0.9 and w * 0.2 < cols.mean() < w * 0.8
    assert np.nonzero(door)[0].mean() < rows.mean()
    # and the picture there is the robot's (light grey), not the floor's or the wall's colour
    img = shot(door_scene, view, proj).astype(float)
    assert np.abs(img[robot].mean(axis=0) - img[door].mean(axis=0)).max() > 30


def test_the_wrist_camera_sees_its_fingers_at_the_bottom(door_scene) -> None:
    view, proj = wrist_view(door_scene)
    fingers = _mask(door_scene, view, proj, "robot")
    h, _ = fingers.shape
    assert fingers[h // 2:].sum() > 20 and fingers[: h // 4].sum() == 0
