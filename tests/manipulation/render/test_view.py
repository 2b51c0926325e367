"""The manipulation camera frames every body of the scene, not a fixed spot of the room."""

from __future__ import annotations

import pytest

pybullet = pytest.importorskip("pybullet")

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
