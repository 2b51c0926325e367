import pytest

from regen.driving.world.maps import ensure_map, geometry, list_maps
from regen.errors import ConfigError


def test_maps_are_generated_into_the_cache_and_reused(tmp_path, monkeypatch):
    monkeypatch.setenv("REGEN_CACHE_DIR", str(tmp_path))
    path = ensure_map("straight")
    assert path.parent == (tmp_path / "maps").resolve()
    assert "<OpenDRIVE" in path.read_text()
    mtime = path.stat().st_mtime_ns
    assert ensure_map("straight").stat().st_mtime_ns == mtime  # cached, not regenerated
    path.unlink()
    assert ensure_map("straight").exists()  # regenerated when missing


def test_unknown_map_is_a_config_error():
    with pytest.raises(ConfigError, match="unknown map"):
        ensure_map("moon_base")


def test_lane_geometry_is_right_hand_traffic():
    g = geometry("straight")
    assert g.lane_center_y(0) == pytest.approx(-1.75)
    assert g.lane_center_y(1) == pytest.approx(-5.25)
    assert g.lane_center_y(-1) == pytest.approx(1.75)


@pytest.mark.slow
@pytest.mark.parametrize("name", list_maps())
def test_every_map_loads_in_scenic_with_the_promised_shape(name):
    pytest.importorskip("scenic")
    from scenic.domains.driving.roads import Network

    net = Network.fromFile(str(ensure_map(name)))
    g = geometry(name)
    assert len(net.sidewalks) >= 2
    if g.junction:
        assert len(net.intersections) == 1
        assert len(net.roads) == len(g.arms)
    else:
        assert len(net.intersections) == 0
        ys = sorted(round(float(lane.centerline.points[0][1]), 2) for lane in net.lanes)
        assert ys == [-5.25, -1.75, 1.75, 5.25]


def test_every_database_pedestrian_walks_and_is_drawn_as_one():
    from regen.driving.assets import database
    from regen.driving.world.actors import PEDESTRIAN_ASSETS, actor_category, scenic_class

    db = database()
    assert set(db.categories["pedestrians"]) == PEDESTRIAN_ASSETS
    for a in PEDESTRIAN_ASSETS:
        assert actor_category(a, db.assets[a].kind) == "pedestrian" and scenic_class(a, db.assets[a].kind) == "Pedestrian"
