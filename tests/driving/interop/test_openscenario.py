"""OpenSCENARIO export: schema-valid, every entity named safely, trajectories from the trace."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

pytest.importorskip("scenariogeneration")
pytest.importorskip("xmlschema")

from regen.core.behavior import Behavior  # noqa: E402
from regen.core.scenario import FSM, Entity, Scenario  # noqa: E402
from regen.core.trace import ActorTrack, Trace  # noqa: E402
from regen.driving.interop.openscenario import export_openscenario, safe_name, validate_xosc  # noqa: E402
from regen.errors import ConfigError  # noqa: E402

DT = 0.1  # [s]


def _case(map_path, names=("ego", "ambulance1", "adult1", "cone1"), narrative="an ambulance passes"):
    """Ego at 8 m/s, an ambulance at 12 m/s, a pedestrian crossing, a cone standing; 3 s."""
    t = np.round(np.arange(0, 3.0 + 1e-9, DT), 6)
    n = len(t)
    ego, amb, ped, cone = names
    actors = {
        ego: ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, x=list(-30 + 8 * t),
                        y=[-1.75] * n, heading=[0.0] * n, speed=[8.0] * n),
        amb: ActorTrack(asset="ambulance", x=list(-50 + 12 * t), y=[-5.25] * n, speed=[12.0] * n,
                        states={"siren": ["on"] * n}),
        ped: ActorTrack(asset="adult", x=[10.0] * n, y=list(-8 + 1.2 * t), heading=[np.pi / 2] * n),
        cone: ActorTrack(asset="traffic_cone", kind="object", x=[20.0] * n, y=[-3.0] * n),
    }
    trace = Trace(dt=DT, times=list(t), actors=actors, meta={"map": "straight", "map_path": str(map_path)})
    scenario = Scenario(
        id="run-1", domain="driving", behavior=Behavior(text="the ego-vehicle slows down", domain="driving"),
        causal_graph=["ambulance approaches", "the ego-vehicle slows down"], narrative=narrative,
        entities=[Entity(name=ego, asset="sedan", kind="ego"),
                  Entity(name=amb, asset="ambulance", properties={"siren": "on"}),
                  Entity(name=ped, asset="adult"), Entity(name=cone, asset="traffic_cone", kind="object")],
        fsm=FSM())
    return scenario, trace


def _objects(root) -> dict[str, ET.Element]:
    return {o.get("name"): o for o in root.iter("ScenarioObject")}


def test_export_validates_and_names_every_entity(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    out = export_openscenario(scenario, trace, tmp_path)
    assert validate_xosc(out["xosc"]) == []
    root = ET.parse(out["xosc"]).getroot()
    objects = _objects(root)
    assert set(objects) == set(trace.actors)
    assert objects["ego"].find("Vehicle") is not None
    assert objects["ambulance1"].find("Vehicle").get("role") == "ambulance"
    assert objects["adult1"].find("Pedestrian") is not None
    assert objects["cone1"].find("MiscObject") is not None
    dims = objects["ego"].find("Vehicle/BoundingBox/Dimensions")
    assert (float(dims.get("length")), float(dims.get("width"))) == (4.6, 1.9)
    # the ambulance's size comes from the asset database when the trace has none
    amb = objects["ambulance1"].find("Vehicle/BoundingBox/Dimensions")
    assert float(amb.get("length")) == pytest.approx(6.4)
    props = {p.get("name"): p.get("value") for p in objects["ambulance1"].iter("Property")}
    assert props["regen_siren"] == "on"


def test_map_is_copied_beside_and_referenced_by_name(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    out = export_openscenario(scenario, trace, tmp_path)
    assert out["xodr"].parent == out["xosc"].parent
    assert out["xodr"].read_bytes() == straight_map.read_bytes()
    logic = ET.parse(out["xosc"]).getroot().find("RoadNetwork/LogicFile")
    assert logic.get("filepath") == out["xodr"].name


def test_initial_poses_and_trajectories_come_from_the_trace(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    out = export_openscenario(scenario, trace, tmp_path, sample_dt=0.5)
    root = ET.parse(out["xosc"]).getroot()
    teleports = {}
    for private in root.iter("Private"):
        pos = private.find("PrivateAction/TeleportAction/Position/WorldPosition")
        if pos is not None:
            teleports[private.get("entityRef")] = (float(pos.get("x")), float(pos.get("y")))
    for name, track in trace.actors.items():
        assert teleports[name] == pytest.approx((track.x[0], track.y[0]))
    paths = {}
    for group in root.iter("ManeuverGroup"):
        actor = group.find("Actors/EntityRef").get("entityRef")
        verts = group.findall(".//Trajectory/Shape/Polyline/Vertex")
        paths[actor] = [(float(v.get("time")), float(v.find("Position/WorldPosition").get("x")))
                        for v in verts]
    # the three movers follow their recorded path; the cone stands still
    assert set(paths) == {"ego", "ambulance1", "adult1"}
    ego = paths["ego"]
    assert [t for t, _ in ego] == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    assert [x for _, x in ego] == pytest.approx([-30 + 8 * t for t, _ in ego])
    stop = root.find("Storyboard/StopTrigger//SimulationTimeCondition")
    assert float(stop.get("value")) == pytest.approx(3.0)


@pytest.mark.parametrize("hostile", ['amb"ulance', "<script>alert(1)</script>", "a b&c", "ünï"])
def test_hostile_names_are_made_safe(straight_map, tmp_path, hostile):
    scenario, trace = _case(straight_map, names=("ego", hostile, "a_b_c", "cone1"),
                            narrative='ends "here" <b>&amp; \x00\x07 bell')
    out = export_openscenario(scenario, trace, tmp_path)
    assert validate_xosc(out["xosc"]) == []
    root = ET.parse(out["xosc"]).getroot()
    names = list(_objects(root))
    assert len(names) == 4 and len(set(names)) == 4  # 'a b&c' and 'a_b_c' do not collide
    assert all(n == safe_name(n) for n in names)
    assert safe_name(hostile) in names or f"{safe_name(hostile)}_2" in names
    text = out["xosc"].read_text("utf-8")
    assert "<script>" not in text and "<b>" not in text
    assert root.find("FileHeader").get("description").endswith('ends "here" <b>&amp;  bell')
    # every reference points at a declared entity
    refs = {e.get("entityRef") for e in root.iter() if e.get("entityRef") is not None}
    assert refs <= set(names)


def test_validator_reports_schema_errors(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    out = export_openscenario(scenario, trace, tmp_path)
    text = out["xosc"].read_text("utf-8").replace('vehicleCategory="car"', 'vehicleCategory="spaceship"')
    bad = tmp_path / "bad.xosc"
    bad.write_text(text, "utf-8")
    errors = validate_xosc(bad)
    assert errors and "spaceship" in errors[0]
    bad.write_text("<OpenSCENARIO><FileHeader", "utf-8")
    assert "not readable XML" in validate_xosc(bad)[0]


def test_no_map_still_exports_a_valid_file(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    trace.meta.clear()
    out = export_openscenario(scenario, trace, tmp_path)
    assert "xodr" not in out
    assert validate_xosc(out["xosc"]) == []


def test_bad_input_is_a_clear_error(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    with pytest.raises(ConfigError, match="no steps"):
        export_openscenario(scenario, Trace(dt=DT, times=[], actors={}), tmp_path)
    with pytest.raises(ConfigError, match="sample_dt"):
        export_openscenario(scenario, trace, tmp_path, sample_dt=0)


def _trajectory_actors(root) -> set[str]:
    return {g.find("Actors/EntityRef").get("entityRef") for g in root.iter("ManeuverGroup")}


def test_only_moving_primitives_are_replayed_as_trajectories(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    trace.actors["cone1"].x = list(np.linspace(20.0, 21.0, trace.steps))  # nudged 1 m in the run
    out = export_openscenario(scenario, trace, tmp_path / "unknown")
    assert "cone1" in _trajectory_actors(ET.parse(out["xosc"]).getroot())  # no primitive: its path decides
    entities = [e.model_copy(update={"behavior": b}) for e, b in
                zip(scenario.entities, ["stop_abruptly", "drive_forward", "cross_the_road", "stationary"],
                    strict=True)]
    out = export_openscenario(scenario.model_copy(update={"entities": entities}), trace, tmp_path / "known")
    assert validate_xosc(out["xosc"]) == []
    assert _trajectory_actors(ET.parse(out["xosc"]).getroot()) == {"ego", "ambulance1", "adult1"}


def _body(obj: ET.Element) -> tuple[float, dict[str, float]]:
    """(mass [kg], Performance attributes) of a ScenarioObject."""
    (entity,) = list(obj)
    perf = entity.find("Performance")
    return float(entity.get("mass")), ({k: float(v) for k, v in perf.attrib.items()} if perf is not None else {})


def test_every_entity_has_its_categorys_mass_and_performance(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    out = export_openscenario(scenario, trace, tmp_path)
    objects = _objects(ET.parse(out["xosc"]).getroot())
    assert _body(objects["ego"]) == (1500.0, {"maxSpeed": 50.0, "maxAcceleration": 4.5, "maxDeceleration": 9.0})
    assert _body(objects["ambulance1"]) == (4500.0, {"maxSpeed": 40.0, "maxAcceleration": 3.0,
                                                     "maxDeceleration": 7.5})
    assert objects["ambulance1"].find("Vehicle").get("vehicleCategory") == "van"
    assert _body(objects["adult1"]) == (75.0, {})  # a Pedestrian: a mass, no Performance in 1.2
    assert _body(objects["cone1"]) == (4.0, {})


def test_a_bicycle_is_exported_with_a_bicycles_mass_and_top_speed_unless_it_rode_faster(straight_map, tmp_path):
    scenario, trace = _case(straight_map)
    bike = trace.actors["ambulance1"].model_copy(update={"asset": "bicycle", "speed": [5.0] * trace.steps})
    trace.actors["ambulance1"] = bike
    entities = [e.model_copy(update={"asset": "bicycle", "properties": {}}) if e.name == "ambulance1" else e
                for e in scenario.entities]
    out = export_openscenario(scenario.model_copy(update={"entities": entities}), trace, tmp_path / "slow")
    assert validate_xosc(out["xosc"]) == []
    obj = _objects(ET.parse(out["xosc"]).getroot())["ambulance1"]
    assert obj.find("Vehicle").get("vehicleCategory") == "bicycle"
    assert _body(obj) == (90.0, {"maxSpeed": 12.0, "maxAcceleration": 1.5, "maxDeceleration": 5.0})
    # a run where it rode at 14.26 m/s and braked at 8 m/s^2: the limits allow the replay
    trace.actors["ambulance1"] = bike.model_copy(update={"speed": [14.26] * (trace.steps - 1) + [13.46]})
    out = export_openscenario(scenario.model_copy(update={"entities": entities}), trace, tmp_path / "fast")
    mass, perf = _body(_objects(ET.parse(out["xosc"]).getroot())["ambulance1"])
    assert (mass, perf["maxSpeed"], perf["maxDeceleration"], perf["maxAcceleration"]) == (90.0, 14.3, 8.0, 1.5)


def test_an_asset_without_physics_gets_its_categorys_nominal_values():
    from regen.assets.database import AssetSpec
    from regen.driving.assets import database
    from regen.driving.interop.physics import NOMINAL, physics

    db = database()
    assert all(db.assets[a].physics is not None for members in db.categories.values() for a in members
               if db.category_of(a) != "sensors")  # the project's database states every body
    bare = db.model_copy(update={"assets": {**db.assets, "bus": AssetSpec(kind="agent", description="bus")}})
    assert physics("bus", "vehicle", bare) == NOMINAL["bus"]
    assert physics("bus", "vehicle", db)[0] == 15000.0
    assert physics("ego", "vehicle", db) == NOMINAL["car"]
    assert physics("unknown", "pedestrian", db) == (75.0, 0.0, 0.0, 0.0)
