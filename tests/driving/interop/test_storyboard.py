"""The OpenSCENARIO storyboard keeps the scenario's triggers: read back as parsed XML, a light that
turns red switches the map's signal on the ego's approach (yellow, then red after the yellow time), a crossing
child starts on the ego's distance (or time to reach) to its crossing point, a car cutting in
starts its lane change at a longitudinal offset from the ego (or at its latest time), each with
the ego as the triggering entity and its recorded path timed from the event's start; the flag
without the ego's story leaves the ego placed but not driven."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest
from driving_chains import FEASIBLE, chain

pytest.importorskip("scenic")

CHILD = FEASIBLE["stop_abruptly"][0]  # a child runs across the road (approach trigger)
CUT_IN = FEASIBLE["slow_down"][2]  # a car cuts in (offset trigger)


def _export(path, folder, **kw):
    from regen.core.scenario import Scenario
    from regen.core.trace import Trace
    from regen.driving.interop.openscenario import export_openscenario
    from regen.pipeline.stages import run_path

    assert run_path(path, folder, pictures=False).verdict.feasible

    sc = Scenario.model_validate(json.loads((folder / "scenario.json").read_text())["scenario"])
    tr = Trace.model_validate_json((folder / "trace.json").read_text())
    out = export_openscenario(sc, tr, folder / "x", **kw)
    return ET.parse(out["xosc"]).getroot(), sc


def _event(root, name: str):
    return next(e for e in root.iter("Event") if e.get("name") == name)


def test_a_crossing_child_starts_on_the_egos_distance_or_time_to_its_crossing_point(tmp_path):
    root, _ = _export(CHILD, tmp_path / "child")
    cause = _event(root, "child1_cause")
    groups = cause.find("StartTrigger").findall("ConditionGroup")
    assert len(groups) == 2  # OR: near enough, or soon enough
    kinds = []
    for g in groups:
        (cond,) = g.findall("Condition")
        entity = cond.find("ByEntityCondition")
        assert entity.find("TriggeringEntities/EntityRef").get("entityRef") == "ego"
        inner = entity.find("EntityCondition")
        kinds.append(inner[0].tag)
        pos = inner[0].find(".//Position/WorldPosition")
        assert pos is not None and float(inner[0].get("value")) > 0
    assert kinds == ["DistanceCondition", "TimeToCollisionCondition"]
    follow = cause.find(".//FollowTrajectoryAction")
    assert follow.find("TimeReference/Timing").get("domainAbsoluteRelative") == "relative"
    vertices = follow.findall(".//Polyline/Vertex")
    assert float(vertices[0].get("time")) == 0.0 and len(vertices) > 2  # timed from the event's start


def test_a_cut_in_starts_at_a_longitudinal_offset_from_the_ego(tmp_path):
    root, sc = _export(CUT_IN, tmp_path / "cut")
    cause = _event(root, "sedan1_cause")
    groups = cause.find("StartTrigger").findall("ConditionGroup")
    rel = groups[0].find("Condition/ByEntityCondition")
    assert rel.find("TriggeringEntities/EntityRef").get("entityRef") == "sedan1"
    cond = rel.find("EntityCondition/RelativeDistanceCondition")
    assert cond.get("entityRef") == "ego" and cond.get("relativeDistanceType") == "longitudinal"
    assert groups[1].find("Condition/ByValueCondition/SimulationTimeCondition") is not None  # at the latest
    # it drives alongside before the trigger: that part is on simulation time
    before = _event(root, "sedan1_before_trigger")
    assert before.find(".//FollowTrajectoryAction/TimeReference/Timing").get("domainAbsoluteRelative") == "absolute"


def test_without_the_egos_story_the_ego_is_placed_but_not_driven(tmp_path):
    from regen.driving.interop.openscenario import validate_xosc

    root, _ = _export(CHILD, tmp_path / "noego", ego_story=False)
    assert any(p.get("entityRef") == "ego" for p in root.iter("Private"))
    actors = [ref.get("entityRef") for g in root.iter("ManeuverGroup") for ref in g.findall("Actors/EntityRef")]
    assert "ego" not in actors and "child1" in actors
    assert validate_xosc(tmp_path / "noego" / "x" / "scenario.xosc") == []


def test_the_backends_export_leaves_the_egos_story_out_on_request(tmp_path):
    """The option as ``regen generate --no-ego-story`` passes it: no ego story, maneuver or
    event, the ego still an entity placed in Init, the child's story kept; schema-valid."""
    from regen.core.scenario import Scenario
    from regen.core.trace import Trace
    from regen.driving.backend import DrivingBackend
    from regen.driving.interop.openscenario import validate_xosc
    from regen.pipeline.stages import redraw_stage, run_path

    folder = tmp_path / "run"
    assert run_path(CHILD, folder, pictures=False).verdict.feasible
    sc = Scenario.model_validate(json.loads((folder / "scenario.json").read_text())["scenario"])
    tr = Trace.model_validate_json((folder / "trace.json").read_text())
    with_ego = ET.parse(folder / "scenario.xosc").getroot()  # the pipeline's default: with it
    assert "ego_story" in [s.get("name") for s in with_ego.iter("Story")]
    files = DrivingBackend().export(sc, tmp_path / "out", trace=tr, ego_story=False)
    assert validate_xosc(files["xosc"]) == []
    # the stage regen generate --no-ego-story runs: the run's export options reach the export
    assert redraw_stage("driving", str(folder), pictures=False, export_options={"ego_story": False})
    assert [s.get("name") for s in ET.parse(folder / "scenario.xosc").getroot().iter("Story")] == ["child1_story"]
    root = ET.parse(files["xosc"]).getroot()
    assert [s.get("name") for s in root.iter("Story")] == ["child1_story"]
    named = [e.get("name") for tag in ("Maneuver", "ManeuverGroup", "Event") for e in root.iter(tag)]
    assert named and not [n for n in named if n.startswith("ego")]
    assert "ego" in {o.get("name") for o in root.iter("ScenarioObject")}
    init = root.find("Storyboard/Init")
    assert any(p.get("entityRef") == "ego" and p.find(".//TeleportAction") is not None for p in init.iter("Private"))


LIGHT = chain("stop_abruptly", "the traffic light ahead turns red", ("traffic_light", {"light_state": ["turns_red"]}))


def test_a_light_that_turns_red_switches_the_maps_signal_on_the_egos_approach(tmp_path):
    from regen.driving.interop.signals import signals_of
    from regen.driving.world.properties import YELLOW_TIME

    root, sc = _export(LIGHT, tmp_path / "light")
    (xodr,) = (tmp_path / "light" / "x").glob("*.xodr")
    signals = signals_of(xodr.read_text())
    (sid,) = [k for k, (name, _, _) in signals.items() if name == "traffic_light1"]
    _, sx, sy = signals[sid]
    light = next(p for p in root.iter("Private") if p.get("entityRef") == "traffic_light1")
    pos = light.find(".//TeleportAction/Position/WorldPosition")
    assert abs(float(pos.get("x")) - sx) < 0.01 and abs(float(pos.get("y")) - sy) < 0.01  # the signal is the light
    (first,) = [a for a in root.iter("TrafficSignalStateAction") if a in list(root.find("Storyboard/Init").iter())]
    assert (first.get("name"), first.get("state")) == (sid, "green")  # green at the start
    changes = []
    for ev in root.iter("Event"):
        action = ev.find(".//TrafficSignalStateAction")
        if action is None:
            continue
        assert action.get("name") == sid
        (cond, *_) = ev.find("StartTrigger").iter("Condition")
        entity = cond.find("ByEntityCondition")
        assert entity.find("TriggeringEntities/EntityRef").get("entityRef") == "ego"  # on the ego's approach
        assert entity.find("EntityCondition/DistanceCondition") is not None
        changes.append((action.get("state"), float(cond.get("delay"))))
    assert changes == [("yellow", 0.0), ("red", YELLOW_TIME)]


def test_every_actor_has_a_story_of_its_own_the_egos_first(tmp_path):
    root, _ = _export(CHILD, tmp_path / "stories")
    stories = root.findall("Storyboard/Story")
    assert [s.get("name") for s in stories] == ["ego_story", "child1_story"]
    for s in stories:
        actors = {r.get("entityRef") for g in s.iter("ManeuverGroup") for r in g.findall("Actors/EntityRef")}
        assert actors == {s.get("name").removesuffix("_story")}
