"""A cyclist crosses the road in front of the ego: cross_the_road ridden by a bicycle (a Scenic
Car following its route with FollowRoute at the crossing riders' speeds), end to end."""

from __future__ import annotations

import pytest

from regen.core import Behavior, CausePath, PathEntity
from regen.driving.primitives import get
from regen.driving.primitives.cross_the_road import RIDE_CROSS_SPEEDS

STOP = "the ego-vehicle stops abruptly while driving forward"
CAUSE = "a cyclist crosses the road in front of the ego-vehicle"
PATH = CausePath(behavior=Behavior(text=STOP, domain="driving", params={"ego_template": "stop_abruptly"}),
                 events=[CAUSE, STOP],
                 entities=[PathEntity(asset="bicycle", event=CAUSE,
                                      properties={"behavior": ["cross_the_road"],
                                                  "start_location": ["roadside_ahead"]})])


def test_a_bicycle_rides_across_where_pedestrians_walk(ground):
    sc, t, plans = ground("stop_abruptly", "bicycle", behavior="cross_the_road",
                          start_location="roadside_ahead")
    p = plans["bicycle1"]
    assert p.cls == "Car" and p.scenic_behavior == "FollowRoute" and p.dynamic
    assert (p.length, p.width) == (1.8, 0.6)  # its length lies along its heading, across the road
    assert p.route[0][1] == pytest.approx(t.frame.sidewalk_d("right"))
    assert p.route[-1][1] == pytest.approx(t.frame.sidewalk_d("left"))
    assert p.trigger is not None  # it sets off as the ego comes near
    lo, hi = RIDE_CROSS_SPEEDS.moderate
    assert lo <= sc.parameters["bicycle1"]["v"] <= hi
    # a child crossing still walks
    spec = get("cross_the_road")
    assert spec.speed_classes("child") != RIDE_CROSS_SPEEDS
    assert spec.scenic_behavior_of("Pedestrian") == "WalkRoute"


def test_the_backend_offers_the_crossing_starts_to_a_bicycle():
    from regen.driving.backend import DrivingBackend

    choices = DrivingBackend().property_choices("bicycle")
    assert choices.key == "behavior"
    assert choices.allowed["cross_the_road"]["start_location"] == ["roadside_ahead", "roadside_opposite_ahead",
                                                               "crosswalk_ahead"]


@pytest.fixture(scope="module")
def crossing(tmp_path_factory):
    """The path run through the pipeline with pictures (rule-based grounding)."""
    pytest.importorskip("scenic")
    from regen.pipeline import run_path

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        folder = tmp_path_factory.mktemp("run") / "cyclist-crosses"
        yield run_path(PATH, folder, pictures=True), folder


@pytest.mark.slow
def test_the_cyclist_crosses_the_egos_lane_ahead_of_it(crossing):
    from regen.core.trace import Trace

    out, folder = crossing
    assert out.verdict.status == "verified", out.verdict.reason
    assert (folder / "bird_eye.gif").is_file() and (folder / "scenario.xosc").is_file()
    trace = Trace.model_validate_json((folder / "trace.json").read_text())
    bike, ego = trace.actors["bicycle1"], trace.actors["ego"]
    lane_y = ego.y[0]  # the ego's lane centre (the frame runs along +x)
    side = [y - lane_y for y in bike.y]
    assert side[0] < -3.0 and side[-1] > 3.0  # from the right-hand kerb to beyond the lane
    in_lane = [k for k, d in enumerate(side) if abs(d) < 1.75]
    assert in_lane and all(bike.x[k] > ego.x[k] for k in in_lane)  # ahead of the ego
    assert max(bike.speed) <= RIDE_CROSS_SPEEDS.moderate[1] + 0.3


@pytest.mark.slow
def test_a_constant_speed_ego_hits_the_cyclist(crossing):
    from regen.driving.testing.loop import prepare, run_policy
    from regen.driving.testing.policies import constant_speed
    from regen.driving.verify.collisions import analyze
    from regen.runfolder import ScenarioFolder

    _, folder = crossing
    episode = run_policy(prepare(ScenarioFolder(folder).scenario()), constant_speed)
    assert episode.failure is None
    assert any(set(c.actors) == {"ego", "bicycle1"} for c in analyze(episode.trace).collisions)
