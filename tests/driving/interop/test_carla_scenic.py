"""``scenario.carla.scenic``: the same scenario for Scenic's CARLA model. For the first
hand-written chain of every ego template it compiles offline in 2D mode and yields a scene,
every actor has the CARLA blueprint of its asset, and CARLA's own parser of the exported map
(the ``carla`` client, offline) finds a waypoint at every actor's start, with CARLA's y axis
flipped: a car's waypoint lies under it and points the way it faces."""

from __future__ import annotations

import math
import os

import pytest
from driving_chains import FEASIBLE

pytest.importorskip("scenic")


def _carla():
    try:
        import carla
    except ImportError:
        if os.environ.get("CI"):
            raise  # setup installs it: CI must not skip this
        pytest.skip("the carla client package is not installed (pip install 'regen-sim[carla]')")
    return carla


@pytest.mark.slow
@pytest.mark.parametrize("tid", sorted(FEASIBLE))
def test_the_carla_program_compiles_and_every_start_lies_on_carlas_map(tmp_path, tid):
    import scenic

    from regen.driving.assets import database
    from regen.pipeline.stages import run_path

    carla = _carla()
    assert run_path(FEASIBLE[tid][0], tmp_path, pictures=False).verdict.feasible
    program = tmp_path / "scenario.carla.scenic"
    text = program.read_text()
    assert "model scenic.simulators.carla.model" in text and "param carla_map" in text
    scene, _ = scenic.scenarioFromFile(str(program), mode2D=True).generate(maxIterations=1)
    db = database()
    xodr = next(tmp_path.glob("*.xodr"))
    world = carla.Map(xodr.stem, xodr.read_text())
    for o in scene.objects:
        asset = o.name.rstrip("0123456789") if o.name != "ego" else "ego"
        if asset in db.assets:
            assert o.blueprint == db.assets[asset].blueprint, o.name
        x, y = o.position.x, o.position.y
        wp = world.get_waypoint(carla.Location(x=x, y=-y, z=0.0), project_to_road=True,
                                lane_type=carla.LaneType.Any)
        assert wp is not None, o.name
        loc = wp.transform.location
        assert math.hypot(loc.x - x, -loc.y - y) < 1.0, (o.name, x, y, loc)
        if o.name == "ego" or str(wp.lane_type) == "Driving" and asset in db.assets and db.assets[asset].kind == "agent" \
                and "walker" not in str(getattr(o, "blueprint", "")):
            facing = math.degrees(o.heading) + 90.0  # Scenic: from +y; the map: from +x
            yaw = -wp.transform.rotation.yaw  # CARLA: y flipped, so yaw flips too
            assert abs((facing - yaw + 180.0) % 360.0 - 180.0) < 15.0, (o.name, facing, yaw)
