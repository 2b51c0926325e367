"""The manipulation camera frames every body of the scene, not a fixed spot of the room."""

from __future__ import annotations

import pytest

pybullet = pytest.importorskip("pybullet")

import numpy as np  # noqa: E402

from regen.manipulation.render.view import HEIGHT, WIDTH, camera, project  # noqa: E402


@pytest.mark.parametrize("steep", [False, True])
def test_a_person_beyond_the_door_is_in_the_picture(steep: bool) -> None:
    # the robot near the origin, a person 2.5 m away behind the wall (the door scenes)
    extent = ((-0.3, -0.4, 0.0), (1.2, 2.6, 1.2))
    person = (0.9, 2.4, 1.1)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        fixed = camera(pybullet, client, steep)
        fitted = camera(pybullet, client, steep, extent)
    finally:
        pybullet.disconnect(client)

    def inside(view_proj, point) -> bool:
        xy = project(point, *view_proj)
        return xy is not None and 0 <= xy[0] < WIDTH and 0 <= xy[1] < HEIGHT

    assert not inside(fixed, person)  # the fixed view cut it off
    corners = [(x, y, 0.0) for x in (extent[0][0], extent[1][0]) for y in (extent[0][1], extent[1][1])]
    assert inside(fitted, person) and all(inside(fitted, c) for c in corners)


def test_labels_of_objects_side_by_side_do_not_print_over_each_other() -> None:
    from regen.manipulation.render.view import free_row

    placed: list[tuple[float, float, float, float]] = []
    rows = []
    for x0 in (100.0, 130.0, 400.0 - 300.0):  # three labels wanting the same row, overlapping
        y = free_row(placed, x0, 50.0, 80.0)
        placed.append((x0, y, x0 + 80.0, y + 11))
        rows.append(y)
    assert rows[0] == 50.0 and len(set(rows)) == 3
    for i, a in enumerate(placed):
        for b in placed[i + 1:]:
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
    # a label with room keeps its own row
    assert free_row(placed, 250.0, 50.0, 40.0) == 50.0


@pytest.fixture(scope="module")
def child_outside():
    """Open the door for a child standing outside it: the cause is behind the wall."""
    from manipulation_chains import door_scenario

    from regen import domains
    from regen.manipulation.simulation.run import rollout

    sc = door_scenario({"child1": ("outside", "door1")}, ["child"])
    trace = rollout(sc).trace
    verdict, _ = domains.make("manipulation").verify(sc, trace)
    return sc, trace, verdict


def _seen(scene, view, proj, name: str) -> int:
    """Pixels of body ``name`` a camera shows (a segmentation render at the picture's size)."""
    from regen.manipulation.render.view import VIEW_H

    seg = np.asarray(scene.p.getCameraImage(WIDTH, VIEW_H, view, proj, renderer=scene.p.ER_TINY_RENDERER,
                                            physicsClientId=scene.client)[4]).reshape(-1)
    return int(((seg >= 0) & ((seg & 0xFFFFFF) == scene.bodies[name].id)).sum())


def test_the_cause_behind_the_wall_is_in_the_picture(child_outside) -> None:
    from regen.manipulation.render.view import scene_camera
    from regen.manipulation.simulation.run import layout_from_scenario
    from regen.manipulation.simulation.scene import Scene

    sc, _, _ = child_outside
    child = next(e.name for e in sc.entities if e.asset == "child")
    assert sc.entity(child).properties.get("location", "").startswith("outside")
    with Scene(layout_from_scenario(sc)[0]) as scene:
        cams = {"before": camera(scene.p, scene.client, True), "now": scene_camera(scene)}
        shown = {k: _seen(scene, *cam, child) for k, cam in cams.items()}
        robot = _seen(scene, *cams["now"], "robot")
        door = scene.bodies["door1"].id  # the wall with the door: moved away, nothing hides the child
        scene.p.resetBasePositionAndOrientation(door, (0, 0, -50), (0, 0, 0, 1), physicsClientId=scene.client)
        whole = {k: _seen(scene, *cam, child) for k, cam in cams.items()}
    # all of it shows (the wall hides none of it), and bigger than in the fixed steep view of before
    assert shown["now"] > 0.9 * whole["now"] and shown["now"] > 1500, (shown, whole)
    assert shown["now"] > 1.5 * shown["before"], (shown, whole)
    assert robot > 1500


def test_run_pictures_are_640x480_with_the_stage_bar(child_outside, tmp_path) -> None:
    from PIL import Image

    from regen import media
    from regen.contract import ANIMATION, KEYFRAMES
    from regen.manipulation.render.view import GIF_FRAMES, VIEW_H, render_run

    sc, trace, verdict = child_outside
    assert verdict.status == "verified"
    out = render_run(sc, trace, verdict, tmp_path)
    gif = Image.open(out[ANIMATION])
    assert gif.size == (640, 480) and gif.size[0] >= 640 and gif.size[1] >= 480
    assert gif.n_frames == GIF_FRAMES
    gif.seek(gif.n_frames - 1)
    assert gif.info["duration"] == media.HOLD_MS
    last = np.asarray(gif.convert("RGB")).astype(int)
    band = last[VIEW_H:]
    assert (np.abs(band - np.asarray(media.CAPTION_BG)).sum(axis=2) < 10).mean() > 0.7  # the caption band
    boxes = band[31:47, 8:8 + 20 * len(verdict.stages)]  # one box per stage, all reached at the end
    assert (np.abs(boxes - np.asarray(media.STAGE_DONE)).sum(axis=2) < 30).sum() > 100 * len(verdict.stages)
    strip = Image.open(out[KEYFRAMES])
    tiles = (strip.size[0] + 4) // (640 + 4)
    assert strip.size == (tiles * 640 + (tiles - 1) * 4, 480) and 4 <= tiles <= 6
