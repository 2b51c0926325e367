import math

import numpy as np

from regen.core.trace import ActorTrack, Trace
from regen.verify.predicates import get_predicate, list_predicates


def _trace():
    n = 50
    t = [i * 0.1 for i in range(n)]
    ego_v = [10.0 if i < 20 else max(0.0, 10.0 - 6.8 * (i - 20) * 0.1) for i in range(n)]
    ego_x = np.cumsum([0.0] + [v * 0.1 for v in ego_v[:-1]]).tolist()
    car_x = [x + 20.0 - i * 0.5 for i, x in enumerate(ego_x)]  # closing in, then overlapping
    return Trace(dt=0.1, times=t, actors={
        "ego": ActorTrack(asset="ego", kind="ego", length=4.6, width=1.9, x=ego_x, y=[-1.75] * n,
                          heading=[0.0] * n, speed=ego_v),
        "car": ActorTrack(asset="sedan", length=4.6, width=1.9, x=car_x, y=[-5.25] * n,
                          heading=[0.0] * n, speed=[5.0] * n,
                          states={"siren": ["on"] * 10 + ["off"] * 40}),
        "ped": ActorTrack(asset="adult", length=0.5, width=0.5, x=[ego_x[0] + 1.0] * n,
                          y=[-1.75] * n, heading=[math.pi / 2] * n, speed=[0.0] * n),
    })


def call(name, args, **params):
    spec = get_predicate(name, "driving")
    return spec.fn(_trace(), args, {**spec.params, **params})


def test_library_has_the_documented_driving_predicates():
    names = {p.name for p in list_predicates("driving")}
    assert {"ahead_of", "behind", "same_lane", "adjacent_lane", "in_front", "braking", "in_junction",
            "light_is", "door_open", "siren_on", "collided", "moving", "stopped"} <= names


def test_relative_position_in_the_second_actors_frame():
    ahead = call("ahead_of", ["car", "ego"])
    assert ahead[0] and not ahead[-1]  # the car starts 20 m ahead and falls behind
    assert call("adjacent_lane", ["car", "ego"]).all()
    assert not call("same_lane", ["car", "ego"]).any()


def test_braking_only_while_decelerating():
    b = call("braking", ["ego"], min_decel=4.0)
    assert not b[:15].any() and b[25:30].all() and not b[-5:].any()


def test_collision_uses_footprints():
    assert call("collided", ["ped", "ego"])[0]
    assert not call("collided", ["car", "ego"]).any()  # adjacent lanes never overlap


def test_property_predicates_read_states():
    s = call("siren_on", ["car"])
    assert s[:10].all() and not s[10:].any()
    assert not call("door_open", ["car"]).any()  # no such state: false, not an error


def test_state_predicates_read_their_own_state_only():
    # the car's siren is on for the first second; it has no door state, so door_open never holds
    siren = call("siren_on", ["car"])
    assert siren[:10].all() and not siren[10:].any()
    assert not call("door_open", ["car"]).any()
    assert not call("hazard_lights_on", ["car"]).any()
