"""Built-in policies on constructed observations, actions, and the SPEC loader (no simulator)."""

from __future__ import annotations

import math
import textwrap

import pytest

from regen.driving.testing.policies import (
    AEB,
    BUILTIN,
    IDM,
    Action,
    ActorState,
    EgoState,
    Observation,
    as_action,
    constant_speed,
    load_policy,
    obstacles_in_path,
    path_frame,
)
from regen.errors import ConfigError

ROUTE = tuple((float(x), -1.75) for x in range(5, 61, 5))  # straight ahead along +x [m]


def _ego(speed=10.0, route=ROUTE) -> EgoState:
    return EgoState(x=0.0, y=-1.75, heading=0.0, speed=speed, length=4.6, width=1.9,
                    cruise_speed=10.0, route_ahead=route)


def _actor(name="car", x=20.0, y=-1.75, vx=0.0, vy=0.0, category="vehicle", asset="sedan",
           length=4.6, width=1.9, heading=0.0, **vis) -> ActorState:
    return ActorState(name=name, category=category, asset=asset, x=x, y=y, heading=heading,
                      vx=vx, vy=vy, length=length, width=width, **vis)


def _obs(*actors, speed=10.0) -> Observation:
    return Observation(t=0.0, dt=0.1, ego=_ego(speed), actors=tuple(actors))


def test_constant_speed_ignores_everything():
    a = constant_speed(_obs(_actor(x=8.0)))
    assert a.acceleration == pytest.approx(0.0) and a.curvature == pytest.approx(0.0)
    assert constant_speed(_obs(speed=5.0)).acceleration > 0


def test_route_curvature_turns_towards_the_route():
    left = tuple((float(x), -1.75 + 0.2 * x) for x in range(5, 40, 5))
    obs = Observation(t=0.0, dt=0.1, ego=_ego(route=left), actors=())
    assert constant_speed(obs).curvature > 0.0  # left is positive


def test_path_frame_and_obstacles():
    s, lat, ux, uy = path_frame(_ego(), 20.0, 0.25)
    assert s == pytest.approx(20.0) and lat == pytest.approx(2.0) and (ux, uy) == (1.0, 0.0)
    obs = _obs(_actor("lead", x=20.0), _actor("next_lane", x=10.0, y=1.75),
               _actor("behind", x=-10.0))
    (lead,) = obstacles_in_path(obs)
    assert lead.name == "lead" and lead.gap == pytest.approx(20.0 - 4.6)


def test_idm_cruises_when_free_and_brakes_behind_a_stopped_car():
    assert IDM()(_obs()).acceleration == pytest.approx(0.0, abs=1e-9)
    assert IDM()(_obs(_actor(x=20.0))).acceleration < -3.0
    # following a leader at its own speed and a comfortable gap: (almost) no braking
    assert IDM()(_obs(_actor(x=40.0, vx=10.0))).acceleration > -1.0


def test_idm_stops_for_a_red_light_ahead_only():
    def light(x, state):
        return _actor("light", x=x, y=-6.0, category="light", asset="traffic_light", length=0.6,
                      width=0.6, heading=math.pi, light_state=state)

    assert IDM()(_obs(light(30.0, "red"))).acceleration < -1.0
    assert IDM()(_obs(light(30.0, "green"))).acceleration == pytest.approx(0.0, abs=1e-9)
    assert IDM()(_obs(light(-10.0, "red"))).acceleration == pytest.approx(0.0, abs=1e-9)  # behind


def test_idm_keeps_clear_of_an_open_door():
    parked = dict(x=20.0, y=-4.5, category="static", asset="parked_car")  # side gap 0.85 m
    assert IDM()(_obs(_actor("p", **parked, door="closed"))).acceleration == pytest.approx(0.0, abs=1e-9)
    assert IDM()(_obs(_actor("p", **parked, door="open"))).acceleration < -1.0


def test_idm_yields_to_a_pedestrian_about_to_cross():
    walker = _actor("adult", x=20.0, y=-6.0, vy=1.5, category="pedestrian", asset="adult",
                    length=0.5, width=0.5)
    assert IDM()(_obs(walker)).acceleration < -1.0
    walking_away = _actor("adult", x=20.0, y=-6.0, vy=-1.5, category="pedestrian", asset="adult",
                          length=0.5, width=0.5)
    assert IDM()(_obs(walking_away)).acceleration == pytest.approx(0.0, abs=1e-9)


def test_aeb_brakes_only_when_time_to_collision_is_short():
    assert AEB()(_obs(_actor(x=30.0))).acceleration == pytest.approx(0.0)  # TTC 2.5 s
    assert AEB()(_obs(_actor(x=15.0))).acceleration == pytest.approx(-6.8)  # TTC 1.0 s
    assert AEB()(_obs(_actor(x=15.0, vx=10.0))).acceleration == pytest.approx(0.0)  # not closing


@pytest.mark.parametrize("value, ok", [
    (Action(1.0, 0.0), True), ((1.0, 0.01), True), ([-2, 0], True),
    ((float("nan"), 0.0), False), (Action(0.0, float("inf")), False), (None, False),
    ("fast", False), (("a", "b"), False),
])
def test_as_action_accepts_finite_actions_only(value, ok):
    if ok:
        assert isinstance(as_action(value), Action)
    else:
        with pytest.raises(ValueError):
            as_action(value)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_builtins_load_and_act(name):
    policy = load_policy(name)
    act = as_action(policy(_obs(_actor(x=40.0))))
    assert math.isfinite(act.acceleration)


def test_load_module_callable():
    assert load_policy("regen.driving.testing.policies:constant_speed") is constant_speed
    assert isinstance(load_policy("regen.driving.testing.policies:IDM"), IDM)  # classes are instantiated


def test_load_a_users_file_from_outside_the_repository(tmp_path):
    f = tmp_path / "elsewhere" / "my_policy.py"
    f.parent.mkdir()
    f.write_text(textwrap.dedent("""
        from regen.driving.testing.policies import Action, route_curvature

        def cautious(obs):
            return Action(-1.0 if obs.ego.speed > 5 else 0.0, route_curvature(obs.ego))
    """))
    policy = load_policy(f"{f}:cautious")
    assert policy(_obs()).acceleration == -1.0


@pytest.mark.parametrize("spec, words", [
    ("nope", "unknown policy"), ("no_such_module_xyz:f", "cannot import"),
    ("regen.driving.testing.policies:missing", "no attribute"), ("/no/such/file.py:f", "does not exist"),
    ("regen.driving.testing.policies:ROUTE_AHEAD", "not callable"),
])
def test_load_errors_name_the_problem(spec, words):
    with pytest.raises(ConfigError, match=words):
        load_policy(spec)
