"""The NHTSA pre-crash typology rules (regen.driving.verify.typology) on hand-built traces: each
rule once on a trace that shows its configuration and once on one that nearly does; then the
data, and three scenarios simulated for real."""

from __future__ import annotations

import math

import numpy as np
import pytest

from regen import domains
from regen.core.behavior import Behavior
from regen.core.scenario import FSM, AbstractState, Entity, PredicateCall, Scenario, Stage, StateRef
from regen.core.trace import ActorTrack, Trace
from regen.driving.verify.typology import RULES, load_classes, typology
from regen.driving.verify.typology_scene import actor_kind, changing_lane, scene_of, turning
from regen.driving.world.egos import EGO_TEMPLATES, JUNCTION_CX

DT = 0.1  # [s]
N = 150  # steps (15 s)
T = np.arange(N) * DT
LANE0, LANE1, ONCOMING = -1.75, -5.25, 1.75  # [m] lane centres of the straight map (east-bound 0, 1; west-bound)


# -- building traces ------------------------------------------------------------------------------


def speeds(*points: tuple[float, float]) -> np.ndarray:
    """A speed profile [m/s] through (t [s], v [m/s]) points, held before the first and after the last."""
    ts, vs = zip(*points, strict=True)
    return np.interp(T, ts, vs)


def along(x0: float, v: np.ndarray | float, direction: float = 1.0) -> np.ndarray:
    """Positions [m] from x0 driving at speeds v (+x, or -x with direction -1)."""
    v = np.broadcast_to(np.asarray(v, float), (N,))
    return x0 + direction * np.concatenate([[0.0], np.cumsum(v[:-1] * DT)])


def shift(y0: float, y1: float, t0: float, t1: float) -> np.ndarray:
    """A smooth sideways move from y0 to y1 between t0 and t1 [s]."""
    s = np.clip((T - t0) / (t1 - t0), 0.0, 1.0)
    return y0 + (y1 - y0) * (3 * s**2 - 2 * s**3)


def track(asset: str, x, y, *, heading=None, kind: str = "agent", size=(4.6, 1.9), states=None) -> ActorTrack:
    """A track through (x, y) [m]; heading from the motion (held while standing) unless given."""
    x = np.broadcast_to(np.asarray(x, float), (N,)).copy()
    y = np.broadcast_to(np.asarray(y, float), (N,)).copy()
    vx, vy = np.gradient(x, DT), np.gradient(y, DT)
    speed = np.hypot(vx, vy)
    if heading is None:
        h = np.arctan2(vy, vx)
        moving = speed > 1e-6
        first = h[np.argmax(moving)] if moving.any() else 0.0
        h = np.where(moving, h, np.nan)
        h[0] = h[0] if moving[0] else first
        for k in range(1, N):  # standing: the last heading
            h[k] = h[k - 1] if np.isnan(h[k]) else h[k]
    else:
        h = np.broadcast_to(np.asarray(heading, float), (N,))
    return ActorTrack(asset=asset, kind=kind, length=size[0], width=size[1], x=x.tolist(), y=y.tolist(),
                      heading=h.tolist(), speed=speed.tolist(), states=states or {})


def turn_path(x0: float, y0: float, h0: float, v: float, t_turn: float, angle: float,
              duration: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, heading) of a vehicle at v [m/s] that turns by ``angle`` [rad] (left positive) over
    ``duration`` [s] from t_turn [s]."""
    yaw = np.where((T >= t_turn) & (T < t_turn + duration), angle / duration, 0.0)
    h = h0 + np.concatenate([[0.0], np.cumsum(yaw[:-1] * DT)])
    x = x0 + np.concatenate([[0.0], np.cumsum(v * np.cos(h[:-1]) * DT)])
    y = y0 + np.concatenate([[0.0], np.cumsum(v * np.sin(h[:-1]) * DT)])
    return x, y, h


def ego(x, y=LANE0, **kw) -> ActorTrack:
    return track("ego", x, y, kind="ego", **kw)


def cruising(v: float = 10.0, x0: float = 0.0, y=LANE0) -> ActorTrack:
    return ego(along(x0, v), y)


def light(states: list[str], x: float = JUNCTION_CX - 13, y: float = -5.0) -> ActorTrack:
    return track("traffic_light", x, y, kind="object", size=(0.3, 0.3), states={"light_state": states})


def make(actors: dict[str, ActorTrack], map_name: str = "straight") -> tuple[Scenario, Trace]:
    fsm = FSM(states=[AbstractState(name="moving", actor="ego", all_of=[PredicateCall(name="moving", args=["ego"])])],
              stages=[Stage(conditions=[StateRef(actor="ego", state="moving")])])
    entities = [Entity(name=n, asset=a.asset, kind="robot" if n == "ego" else "object" if a.kind == "object" else "agent")
                for n, a in actors.items()]
    behavior = Behavior(text="the ego-vehicle stops abruptly", domain="driving")
    scenario = Scenario(id="t", domain="driving", behavior=behavior, causal_graph=["a cause", behavior.text],
                        narrative="", entities=entities, fsm=fsm)
    return scenario, Trace(dt=DT, times=T.tolist(), actors=actors, meta={"map": map_name})


def classes(actors: dict[str, ActorTrack], map_name: str = "straight") -> list[str]:
    return typology().classify(*make(actors, map_name))


def numbers(actors: dict[str, ActorTrack], map_name: str = "straight") -> list[int]:
    return [typology().get(c).number for c in classes(actors, map_name)]


# -- a road user or object in the ego's path (10-15, 36, 37) --------------------------------------

#: a pedestrian that crosses the ego's lane at x = 60 m, in it from t = 4 s (the ego at 10 m/s 20 m short)
def crossing(asset: str = "adult", x: float = 60.0, t0: float = 1.0, v: float = 1.5) -> ActorTrack:
    return track(asset, x, np.clip(-8.0 + v * np.maximum(T - t0, 0), -8.0, 8.0), size=(0.5, 0.5))


def lane_changing_ego(t0: float = 1.0, t1: float = 3.5) -> ActorTrack:
    return ego(along(0.0, 10.0), shift(LANE1, LANE0, t0, t1))


@pytest.mark.parametrize("asset,straight,maneuver", [
    ("adult", 13, 12), ("child", 13, 12), ("bicycle", 15, 14), ("deer", 11, 10), ("debris", 37, 36)])
def test_a_road_user_crossing_the_ego_path_by_its_kind_and_the_egos_maneuver(asset, straight, maneuver):
    assert numbers({"ego": cruising(), "a": crossing(asset)}) == [straight]
    assert numbers({"ego": lane_changing_ego(), "a": crossing(asset)}) == [maneuver]


def test_a_pedestrian_beside_or_behind_the_ego_is_not_in_its_path():
    assert numbers({"ego": cruising(), "a": track("adult", along(20.0, 1.5), -8.0, size=(0.5, 0.5))}) == []
    assert numbers({"ego": cruising(x0=50.0), "a": crossing(x=40.0)}) == []  # behind the ego
    stopped = ego(0.0)  # the ego stands the whole time: nothing approaches the pedestrian
    assert numbers({"ego": stopped, "a": crossing(x=10.0)}) == []


def test_an_object_on_the_roadside_is_not_in_the_path():
    assert numbers({"ego": cruising(), "a": track("debris", 60.0, -8.0, size=(1.0, 1.0), kind="object")}) == []
    assert numbers({"ego": cruising(), "a": track("debris", 60.0, LANE0, size=(1.0, 1.0), kind="object")}) == [37]


# -- lead vehicles (23-27) ------------------------------------------------------------------------


def braking_ego(stop_at: float = 6.0) -> ActorTrack:
    return ego(along(0.0, speeds((stop_at - 2.0, 10.0), (stop_at, 0.0))))


def test_lead_vehicle_stopped_in_the_lane_not_in_the_next_lane():
    assert numbers({"ego": braking_ego(), "car": track("sedan", 60.0, LANE0)}) == [27]
    assert numbers({"ego": braking_ego(), "car": track("sedan", 60.0, LANE1)}) == []


def test_lead_vehicle_decelerating_not_at_a_steady_speed():
    lead = track("sedan", along(20.0, speeds((3.0, 10.0), (5.5, 0.0))), LANE0)
    assert "lead_vehicle_decelerating" in classes({"ego": braking_ego(7.0), "car": lead})
    same_speed = track("sedan", along(20.0, 10.0), LANE0)
    assert classes({"ego": cruising(), "car": same_speed}) == []


def test_lead_vehicle_slower_at_a_steady_speed_not_a_faster_one():
    assert numbers({"ego": cruising(), "car": track("truck", along(35.0, 5.0), LANE0, size=(7.5, 2.5))}) == [25]
    assert numbers({"ego": cruising(), "car": track("truck", along(35.0, 15.0), LANE0, size=(7.5, 2.5))}) == []


def test_lead_vehicle_accelerating_ahead_not_behind():
    lead = track("suv", along(12.0, speeds((1.0, 0.0), (6.0, 10.0))), LANE0)
    follower = ego(along(0.0, speeds((1.5, 0.0), (7.0, 10.0))))
    assert numbers({"ego": follower, "car": lead}) == [24]
    behind = track("suv", along(-15.0, speeds((1.0, 0.0), (6.0, 10.0))), LANE0)
    assert numbers({"ego": follower, "car": behind}) == []


def test_following_vehicle_maneuver_after_the_egos_lane_change_not_without_it():
    slow = track("truck", along(40.0, 4.0), LANE0, size=(7.5, 2.5))
    got = classes({"ego": ego(along(0.0, 10.0), shift(LANE1, LANE0, 1.0, 3.0)), "car": slow})
    assert "following_vehicle_maneuver" in got
    assert "following_vehicle_maneuver" not in classes({"ego": cruising(), "car": slow})


# -- same direction (17-20) -----------------------------------------------------------------------


def test_a_car_cutting_in_close_changes_lanes_not_one_far_ahead():
    cut_in = track("sedan", along(-20.0, 15.0), shift(LANE1, LANE0, 3.0, 5.0))  # overtakes, cuts in ~10 m ahead
    assert numbers({"ego": cruising(), "car": cut_in}) == [19]
    far = track("sedan", along(60.0, 15.0), shift(LANE1, LANE0, 3.0, 5.0))
    assert 19 not in numbers({"ego": cruising(), "car": far})


def test_drifting_alongside_not_holding_the_lane():
    drifting = track("sedan", along(0.0, 10.0), shift(LANE1, LANE1 + 1.5, 2.0, 12.0))  # 0.15 m/s sideways
    assert numbers({"ego": cruising(), "car": drifting}) == [20]
    assert numbers({"ego": cruising(), "car": track("sedan", along(0.0, 10.0), LANE1)}) == []


def test_a_car_pulling_over_ahead_parks_one_changing_lanes_does_not():
    parks = track("sedan", along(25.0, speeds((2.0, 8.0), (5.0, 0.0))), shift(LANE0, -6.0, 2.0, 5.0))
    assert "parking_same_direction" in classes({"ego": ego(along(0.0, speeds((3.0, 8.0), (6.0, 2.0)))), "car": parks})
    keeps_going = track("sedan", along(25.0, 8.0), shift(LANE0, LANE1, 2.0, 5.0))
    assert "parking_same_direction" not in classes({"ego": ego(along(0.0, 8.0)), "car": keeps_going})


def test_a_car_ahead_turning_at_the_junction_same_direction_not_going_straight():
    x0 = JUNCTION_CX - 50
    x, y, h = turn_path(x0 + 15, LANE0, 0.0, 8.0, 4.0, -math.pi / 2)  # turns right into the south arm
    assert 17 in numbers({"ego": ego(along(x0, 8.0)), "car": track("sedan", x, y, heading=h)}, "four_way")
    straight = track("sedan", along(x0 + 15, 8.0), LANE0)
    assert 17 not in numbers({"ego": ego(along(x0, 8.0)), "car": straight}, "four_way")


# -- opposite direction (21, 22) ------------------------------------------------------------------


def test_a_wrong_way_car_head_on_with_and_without_a_maneuver_not_one_in_its_own_lane():
    wrong_way = track("sedan", along(120.0, 8.0, -1.0), LANE0)
    assert numbers({"ego": braking_ego(8.0), "car": wrong_way}) == [22]
    swerving = ego(along(0.0, 10.0), shift(LANE0, LANE1, 4.0, 6.0))
    assert 21 in numbers({"ego": swerving, "car": wrong_way})
    assert numbers({"ego": cruising(), "car": track("sedan", along(120.0, 8.0, -1.0), ONCOMING)}) == []


# -- junctions (5, 28-32) -------------------------------------------------------------------------

X_APPROACH = JUNCTION_CX - 60  # [m] where the ego starts, 60 m before the junction's centre


def through(v: float = 8.0) -> ActorTrack:
    """The ego driving east straight through the four-way junction (at its centre at t = 7.5 s)."""
    return ego(along(X_APPROACH, v))


def from_south(turn: float = 0.0, t_turn: float = 6.0) -> ActorTrack:
    """A car coming north on the south arm (x = 163.75), in the junction around t = 7.5 s."""
    x, y, h = turn_path(JUNCTION_CX + 1.75, -60.0, math.pi / 2, 8.0, t_turn, turn, 1.5)
    return track("sedan", x, y, heading=h)


def oncoming_turning_left() -> ActorTrack:
    """A car coming west on the east arm that turns left (south) in the junction."""
    x, y, h = turn_path(JUNCTION_CX + 60, ONCOMING, math.pi, 8.0, 6.5, math.pi / 2, 2.0)
    return track("suv", x, y, heading=h)


def test_left_turn_across_the_path_from_the_opposite_direction_with_and_without_a_light():
    assert numbers({"ego": through(), "car": oncoming_turning_left()}, "four_way") == [30]
    green = light(["green"] * N)
    assert numbers({"ego": through(), "car": oncoming_turning_left(), "light": green}, "four_way") == [28]
    straight = track("suv", along(JUNCTION_CX + 60, 8.0, -1.0), ONCOMING)
    assert numbers({"ego": through(), "car": straight}, "four_way") == []


def test_straight_crossing_paths_without_a_light_is_31_with_one_running_red():
    assert numbers({"ego": through(), "car": from_south()}, "four_way") == [31]
    assert numbers({"ego": through(), "car": from_south(), "light": light(["green"] * N)}, "four_way") == [5]


def test_a_car_from_the_cross_street_turning_right_is_29_with_a_light_and_32_without():
    right = from_south(turn=-math.pi / 2, t_turn=6.0)  # turns east, into the ego's way
    assert numbers({"ego": through(), "car": right, "light": light(["green"] * N)}, "four_way") == [29]
    assert numbers({"ego": through(), "car": right}, "four_way") == [32]


def test_running_red_light_needs_a_vehicle_entering_on_red():
    turns_red = ["green"] * 30 + ["yellow"] * 20 + ["red"] * (N - 50)
    stops = ego(along(X_APPROACH, speeds((4.0, 8.0), (6.5, 0.0))))  # stands before the junction
    assert numbers({"ego": stops, "light": light(turns_red)}, "four_way") == []
    runner = track("sedan", JUNCTION_CX + 1.75 + np.zeros(N), along(-70.0, 10.0))  # enters at t ~ 5.8 s, on red
    assert numbers({"ego": stops, "car": runner, "light": light(turns_red)}, "four_way") == [5]


def test_running_a_stop_sign_without_stopping_not_after_stopping():
    sign = track("stop_sign", JUNCTION_CX - 13, -5.0, kind="object", size=(0.3, 0.3))
    assert 6 in numbers({"ego": through(), "sign": sign}, "four_way")
    halts = ego(along(X_APPROACH, speeds((3.0, 8.0), (5.0, 0.0), (6.5, 0.0), (8.5, 8.0))))
    assert 6 not in numbers({"ego": halts, "sign": sign}, "four_way")


# -- road departure and backing (7, 8, 9, 16) -----------------------------------------------------


def off_road_from(k: int) -> dict[str, list]:
    return {"on_road": [True] * k + [False] * (N - k)}


def test_road_departure_going_straight_after_a_maneuver_and_backing():
    assert numbers({"ego": ego(along(0.0, 10.0), states=off_road_from(80))}) == [8]
    assert numbers({"ego": ego(along(0.0, 10.0), shift(LANE0, -8.0, 6.0, 8.0), states=off_road_from(80))}) == [7]
    backing = ego(along(0.0, 2.0, -1.0), heading=0.0, states=off_road_from(80))
    assert numbers({"ego": backing}) == [9]
    assert numbers({"ego": ego(along(0.0, 10.0), states={"on_road": [True] * N})}) == []


def test_backing_into_a_vehicle_behind_not_with_nothing_behind():
    backing = ego(along(0.0, speeds((1.0, 0.0), (2.0, 1.5), (5.0, 1.5), (6.0, 0.0))) * -1, heading=0.0)
    assert numbers({"ego": backing, "car": track("sedan", -12.0, LANE0)}) == [16]
    assert numbers({"ego": backing, "car": track("sedan", -12.0, LANE1)}) == []


# -- evasive action (33, 34) ----------------------------------------------------------------------


def test_swerving_from_a_close_hazard_is_evasive_passing_a_slow_car_is_not():
    debris = track("debris", 55.0, LANE0, kind="object", size=(1.0, 1.0))
    swerve = ego(along(0.0, 10.0), shift(LANE0, LANE1, 3.0, 5.0))  # starts 25 m before the debris
    got = numbers({"ego": swerve, "debris": debris})
    assert 34 in got and 33 not in got
    slow = track("truck", along(45.0, 5.0), LANE0, size=(7.5, 2.5))
    assert not {33, 34} & set(numbers({"ego": swerve, "car": slow}))


def test_swerving_after_a_turn_is_evasive_with_prior_maneuver():
    x, y, h = turn_path(0.0, LANE0 - 5.0, 0.6, 10.0, 0.0, -0.6, 1.0)  # bends onto the lane, straight by t = 1 s
    ys = y + shift(0.0, LANE1 - LANE0, 3.2, 5.2)
    swerve = track("ego", x, ys, kind="ego")
    debris = track("debris", float(x[32]) + 27.0, float(y[32]), kind="object", size=(1.0, 1.0))
    assert 33 in numbers({"ego": swerve, "debris": debris})


# -- the scene's motions --------------------------------------------------------------------------


def test_the_end_of_a_turn_is_no_lane_change():
    x, y, h = turn_path(0.0, 0.0, 0.0, 6.0, 3.0, -math.pi / 2, 3.0)
    scene = scene_of(*make({"ego": track("ego", x, y, heading=h, kind="ego")}))
    assert turning(scene.ego, DT).any() and not changing_lane(scene.ego, DT).any()
    scene = scene_of(*make({"ego": lane_changing_ego()}))
    assert changing_lane(scene.ego, DT).any() and not turning(scene.ego, DT).any()


def test_actor_kinds_follow_the_database_then_the_words():
    assert [actor_kind(a) for a in ("sedan", "traffic_queue", "bicycle", "child", "road_worker", "parked_car",
                                    "traffic_light")] == ["vehicle", "vehicle", "cyclist", "pedestrian",
                                                          "pedestrian", "object", "signal"]
    assert [actor_kind(a) for a in ("deer", "stray_dog", "stop_sign", "van", "gnss", "lamppost")] == \
        ["animal", "animal", "stop_sign", "vehicle", "sensor", "other"]
    assert actor_kind("camera", "sensor") == "sensor"


# -- the data and the backend ---------------------------------------------------------------------


def test_the_37_classes_are_data_with_rules_and_causes_that_fit_ego_templates():
    name, source, data = load_classes()
    assert "DOT HS 810 767" in source and [c.number for c in data] == list(range(1, 38))
    assert data[26].name == "Lead vehicle stopped" and data[27].name.startswith("Left turn across path")
    assert {c.number for c in data if c.id not in RULES} == {1, 2, 3, 4, 35}  # nothing in a trace shows them
    for c in data:
        assert c.description and c.name
        assert c.simulable or c.note, c.id
        assert all(set(cause.fits) <= set(EGO_TEMPLATES) and cause.fits for cause in c.causes), c.id
        if c.simulable:
            assert c.causes, f"{c.id}: a simulable class names causes that present it"


def test_the_driving_backend_declares_the_typology_and_its_fill_causes():
    typ = domains.make("driving").typology()
    assert typ is typology() and len(typ.classes) == 37
    stop = Behavior(text="the ego-vehicle stops abruptly while driving forward", domain="driving")
    assert typ.behavior_key(stop) == "stop_abruptly"
    assert typ.fill_causes(stop, "lead_vehicle_stopped") == ["a vehicle ahead is stopped in the lane"]
    assert typ.fill_causes(stop, "pedestrian_with_maneuver") == []  # the ego goes straight
    assert typ.fill_causes(stop, "vehicle_failure") == []  # not simulable
    lane = Behavior(text="the ego-vehicle changes lanes while driving forward", domain="driving")
    assert typ.fill_causes(lane, "pedestrian_with_maneuver") == ["a pedestrian steps into the road ahead"]
    assert domains.make("manipulation").typology() is None


def test_a_trace_without_the_ego_shows_nothing():
    scenario, trace = make({"ego": cruising(), "a": crossing()})
    trace = trace.model_copy(update={"actors": {"a": trace.actors["a"]}})
    assert typology().classify(scenario.model_copy(update={"entities": scenario.entities[1:]}), trace) == []


# -- scenarios simulated for real -----------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("key,i,expected", [
    ("stop_abruptly", 0, [13]),  # a child runs across the road
    ("stop_abruptly", 4, [27]),  # a police checkpoint stands in the lane
    ("slow_down", 2, [19]),  # a car cuts in
    ("stop_in_intersection", 1, [30]),  # an oncoming car turns left across
    ("stop_after_turn", 0, [12]),  # a pedestrian crosses the side road after the ego turned
])
def test_simulated_chains_fall_into_their_classes(chain_result, key, i, expected):
    r = chain_result(key, i)
    assert r.verdict.feasible
    got = [typology().get(c).number for c in typology().classify(r.scenario(), r.trace())]
    assert got == expected
