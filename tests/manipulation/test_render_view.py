"""The manipulation camera frames every body of the scene, not a fixed spot of the room."""

from __future__ import annotations

import pytest

pybullet = pytest.importorskip("pybullet")

from regen.manipulation.render import HEIGHT, WIDTH, _camera, _project  # noqa: E402


@pytest.mark.parametrize("steep", [False, True])
def test_a_person_beyond_the_door_is_in_the_picture(steep: bool) -> None:
    # the robot near the origin, a person 2.5 m away behind the wall (the door scenes)
    extent = ((-0.3, -0.4, 0.0), (1.2, 2.6, 1.2))
    person = (0.9, 2.4, 1.1)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        fixed = _camera(pybullet, client, steep)
        fitted = _camera(pybullet, client, steep, extent)
    finally:
        pybullet.disconnect(client)

    def inside(view_proj, point) -> bool:
        xy = _project(point, *view_proj)
        return xy is not None and 0 <= xy[0] < WIDTH and 0 <= xy[1] < HEIGHT

    assert not inside(fixed, person)  # the fixed view cut it off
    corners = [(x, y, 0.0) for x in (extent[0][0], extent[1][0]) for y in (extent[0][1], extent[1][1])]
    assert inside(fitted, person) and all(inside(fitted, c) for c in corners)
