"""The reference driver's rules on hand-built observations (no simulator).

The ego drives along +x in the right lane (y = -1.75) at its cruise speed of 10 m/s unless a test
says otherwise; every rule is checked against a case where it must not fire.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from regen.driving.testing.policies import MAX_BRAKE, ActorState, EgoState, Observation
from regen.driving.testing.reference import Lanes, ReferenceDriver

ROUTE = tuple((float(x), -1.75) for x in range(5, 61, 5))  # straight ahead along +x [m]
LEFT = Lanes((3.5,))  # one more lane in its direction, to the left (y = +1.75)
CHANGE_SPEED = 10.0  # [m/s] its cruise speed


def _ego(x=0.0, speed=10.0, cruise=10.0) -> EgoState:
    route = tuple((x + px, py) for px, py in ROUTE)  # the same 60 m ahead, wherever it is
    return EgoState(x=x, y=-1.75, heading=0.0, speed=speed, length=4.6, width=1.9,
                    cruise_speed=cruise, route_ahead=route)


def _actor(name="car", x=20.0, y=-1.75, vx=0.0, vy=0.0, category="vehicle", asset="sedan",
           length=4.6, width=1.9, heading=0.0, **vis) -> ActorState:
    return ActorState(name=name, category=category, asset=asset, x=x, y=y, heading=heading,
                      vx=vx, vy=vy, length=length, width=width, **vis)


def _obs(*actors, x=0.0, speed=10.0, cruise=10.0, t=0.0) -> Observation:
    return Observation(t=t, dt=0.1, ego=_ego(x, speed, cruise), actors=tuple(actors))


def _accel(*actors, lanes=None, **ego) -> float:
    """A fresh driver's acceleration on one observation."""
    driver = ReferenceDriver(lanes) if lanes is not None else ReferenceDriver()
    return driver(_obs(*actors, **ego)).acceleration


def _light(state, x=30.0, y=-6.0, name="light") -> ActorState:
    return _actor(name, x=x, y=y, category="light", asset="traffic_light", length=0.6, width=0.6,
                  light_state=state)


def _walker(vy, x=20.0, y=-6.0, vx=0.0) -> ActorState:
    return _actor("adult", x=x, y=y, vx=vx, vy=vy, category="pedestrian", asset="adult", length=0.5,
                  width=0.5)


def _debris(x=30.0, y=-1.75, name="debris") -> ActorState:
    return _actor(name, x=x, y=y, category="static", asset="debris", length=1.0, width=1.0)


def _ambulance(x=-30.0, vx=20.0, siren="on") -> ActorState:
    return _actor("ambulance", x=x, vx=vx, asset="ambulance", length=6.0, width=2.2, siren=siren)


def _police(x=30.0, siren="on") -> ActorState:
    return _actor("police", x=x, asset="police_car", siren=siren)


def _target_after(driver: ReferenceDriver, *actors, calls=1, **ego) -> float:
    for _ in range(calls):
        driver(_obs(*actors, **ego))
    return driver.target


# --- 1. car following (IDM) ---------------------------------------------------------------------


def test_cruises_free_and_brakes_behind_a_stopped_car_in_its_path():
    assert _accel() == pytest.approx(0.0, abs=1e-9)  # at its cruise speed on a free road
    assert _accel(speed=5.0) > 1.0  # below it: speeds up
    assert _accel(_actor(x=20.0)) < -3.0  # a stopped car 15.4 m ahead in its lane
    assert _accel(_actor(x=20.0, y=5.25)) == pytest.approx(0.0, abs=1e-9)  # two lanes over: not in its path
    assert _accel(_actor(x=-20.0)) == pytest.approx(0.0, abs=1e-9)  # behind it


def test_follows_a_leader_at_its_own_speed_without_braking_hard():
    assert _accel(_actor(x=40.0, vx=10.0)) > -1.0


# --- 2. traffic lights --------------------------------------------------------------------------


def test_stops_for_a_red_light_near_its_path_only():
    assert _accel(_light("red")) < -1.0
    assert _accel(_light("green")) == pytest.approx(0.0, abs=1e-9)
    assert _accel(_light("red", y=-20.0)) == pytest.approx(0.0, abs=1e-9)  # far beside its path
    assert _accel(_light("red", x=-10.0)) == pytest.approx(0.0, abs=1e-9)  # behind it


def test_drives_through_a_yellow_light_too_close_to_stop_for():
    # stop line 2 m before the light: at 10 m/s it needs 100 / (2 * 3) = 16.7 m to stop at 3 m/s^2
    assert _accel(_light("yellow", x=30.0)) < -1.0  # 25.7 m to the line: stops
    assert _accel(_light("yellow", x=15.0)) == pytest.approx(0.0, abs=1e-9)  # 10.7 m: goes through


# --- 3. yielding to people ----------------------------------------------------------------------


def test_yields_to_a_pedestrian_entering_its_path_not_one_walking_away():
    assert _accel(_walker(vy=1.5)) < -1.0  # 4.25 m beside, towards the path: enters within 3 s
    assert _accel(_walker(vy=-1.5)) == pytest.approx(0.0, abs=1e-9)  # walking away
    assert _accel(_walker(vy=0.2)) == pytest.approx(0.0, abs=1e-9)  # too slow to matter
    assert _accel(_walker(vy=1.5, y=-20.0)) == pytest.approx(0.0, abs=1e-9)  # not within 3 s


def test_waits_for_a_pedestrian_just_beside_its_path():
    # centre 2.5 m beside the path: 1 m beyond its reach (1.5 m), within the 1.5 m pedestrian
    # margin, standing still
    assert _accel(_walker(vy=0.0, y=-1.75 - 2.5)) < -1.0
    assert _accel(_walker(vy=0.0, y=-1.75 - 6.0)) == pytest.approx(0.0, abs=1e-9)


def test_passes_a_pedestrian_walking_along_the_pavement_beside_its_path():
    # the same place, 2.5 m beside the path, walking along it (either way): passed, not waited for
    assert _accel(_walker(vx=-1.2, vy=0.0, y=-1.75 - 2.5)) == pytest.approx(0.0, abs=1e-9)
    assert _accel(_walker(vx=1.2, vy=0.0, y=-1.75 - 2.5)) == pytest.approx(0.0, abs=1e-9)
    # walking along but edging towards the path: still waited for
    assert _accel(_walker(vx=-1.2, vy=0.4, y=-1.75 - 2.5)) < -1.0


# --- 4. emergency vehicles ----------------------------------------------------------------------


def test_gives_way_to_an_emergency_vehicle_with_its_siren_on_closing_in():
    assert _accel(_ambulance()) < -3.0  # 30 m behind, 10 m/s faster
    assert _accel(_ambulance(siren="off")) == pytest.approx(0.0, abs=1e-9)
    assert _accel(_ambulance(x=-60.0)) == pytest.approx(0.0, abs=1e-9)  # beyond 40 m
    assert _accel(_ambulance(vx=5.0)) == pytest.approx(0.0, abs=1e-9)  # falling behind


def test_the_give_way_stop_line_is_fixed_where_it_first_noticed_the_siren():
    driver = ReferenceDriver()
    first = _obs(_ambulance(x=-30.0))
    (line,) = driver._give_way(first)
    assert line.name == "ambulance" and line.gap == pytest.approx(12.0)
    driver(first)
    moved = _obs(_ambulance(x=-20.0), x=5.0, t=0.5)  # 5 m on, the ambulance still closing in
    (line,) = driver._give_way(moved)
    assert line.gap == pytest.approx(7.0)  # the same line, now nearer (not 12 m ahead again)
    a_moved = driver(moved).acceleration
    # a fresh driver noticing it only now would stop 12 m ahead: it brakes less
    fresh = ReferenceDriver()
    (line,) = fresh._give_way(moved)
    assert line.gap == pytest.approx(12.0)
    assert a_moved <= fresh(moved).acceleration


def test_the_give_way_stop_line_is_forgotten_once_the_vehicle_no_longer_closes_in():
    driver = ReferenceDriver()
    driver(_obs(_ambulance(x=-30.0)))
    assert driver._give_way(_obs(_ambulance(x=-30.0, siren="off"), x=5.0)) == []
    (line,) = driver._give_way(_obs(_ambulance(x=-20.0), x=5.0))  # noticed anew
    assert line.gap == pytest.approx(12.0)


# --- 5. checkpoints -----------------------------------------------------------------------------


def test_stops_at_a_checkpoint_and_does_not_go_around_it():
    driver = ReferenceDriver(LEFT)
    speed = 10.0
    for i in range(6):
        act = driver(_obs(_police(), x=float(i), speed=speed, t=0.1 * i))
        assert act.acceleration < -1.0
        assert driver.target == 0.0 and driver.offset == 0.0
        speed = max(speed + act.acceleration * 0.1, 0.0)
    # the same standing police car with its siren off is a car stopped in traffic: waits too
    assert _target_after(ReferenceDriver(LEFT), _police(siren="off"), calls=5) == 0.0
    # but a broken-down car (hazard lights on) in the same place is gone around: the free lane
    # was really usable
    broken = replace(_police(siren="off"), name="broken_down", hazard_lights="on")
    assert _target_after(ReferenceDriver(LEFT), broken, speed=CHANGE_SPEED) == 3.5


def test_stands_at_a_checkpoint():
    act = ReferenceDriver(LEFT)(_obs(_police(x=25.0), speed=0.0))
    assert act.acceleration == pytest.approx(-MAX_BRAKE)


# --- 6. hazards beside its lane -----------------------------------------------------------------


def test_slows_for_a_hazard_beside_its_lane():
    beside = _debris(x=20.0, y=-1.75 - 3.25)  # 1 m beyond the lane edge (1.75 m from its centre)
    far = _debris(x=20.0, y=-1.75 - 10.0)
    a_beside, a_far = _accel(beside), _accel(far)
    assert a_far == pytest.approx(0.0, abs=1e-9)  # at cruise, nothing to slow for
    assert a_beside < -1.0  # desired speed down to 0.6 of the cruise speed
    assert _accel(_debris(x=-10.0, y=-1.75 - 3.25)) == pytest.approx(0.0, abs=1e-9)  # passed it
    assert _accel(_debris(x=50.0, y=-1.75 - 3.25)) == pytest.approx(0.0, abs=1e-9)  # beyond reach


def test_a_vehicle_with_its_hazard_lights_on_beside_the_lane_is_a_hazard():
    parked = dict(x=20.0, y=-1.75 - 3.0)
    assert _accel(_actor("parked", **parked, hazard_lights="on")) < -1.0
    assert _accel(_actor("parked", **parked, hazard_lights="off")) == pytest.approx(0.0, abs=1e-9)


def test_below_the_hazard_speed_it_still_speeds_up_towards_it():
    beside = _debris(x=20.0, y=-1.75 - 3.25)
    assert _accel(beside, speed=4.0) > 0.0  # 0.6 * 10 = 6 m/s desired


# --- 7. lane changes (MOBIL) --------------------------------------------------------------------


def test_changes_lane_around_debris_at_cruise_speed():
    driver = ReferenceDriver(LEFT)
    driver(_obs(_debris()))  # 30 m ahead in its lane, at its cruise speed of 10 m/s
    assert driver.target == 3.5


def test_changes_lane_around_debris_in_its_lane():
    driver = ReferenceDriver(LEFT)
    driver(_obs(_debris(), speed=CHANGE_SPEED))
    assert driver.target == 3.5
    assert driver.offset == pytest.approx(0.1)  # 1 m/s for one 0.1 s step
    # committed: it keeps moving across even once the debris is out of sight
    driver(_obs(t=0.1, speed=CHANGE_SPEED))
    assert driver.target == 3.5 and driver.offset == pytest.approx(0.2)


def test_does_not_change_lane_in_front_of_a_fast_follower():
    follower = _actor("overtaker", x=-8.0, y=1.75, vx=20.0)  # 3.4 m bumper gap, 10 m/s faster
    driver = ReferenceDriver(LEFT)
    assert _target_after(driver, _debris(), follower, calls=3, speed=CHANGE_SPEED) == 0.0
    assert driver.offset == 0.0
    # the same car far behind in that lane does not keep it from changing
    far = _actor("overtaker", x=-120.0, y=1.75, vx=20.0)
    assert _target_after(ReferenceDriver(LEFT), _debris(), far, speed=CHANGE_SPEED) == 3.5


def test_does_not_change_lane_without_lanes():
    driver = ReferenceDriver()
    for i in range(5):
        driver(_obs(_debris(), t=0.1 * i, speed=CHANGE_SPEED))
        assert driver.target == 0.0 and driver.offset == 0.0


def test_does_not_change_lane_with_nothing_blocking():
    assert _target_after(ReferenceDriver(LEFT), calls=3) == 0.0
    assert _target_after(ReferenceDriver(LEFT), _actor(x=40.0, vx=10.0), calls=3) == 0.0  # at its speed


def test_does_not_change_lane_for_a_person():
    walker = _walker(vy=0.0, y=-1.75, x=30.0)
    assert _target_after(ReferenceDriver(LEFT), walker, calls=3, speed=CHANGE_SPEED) == 0.0


def test_reset_forgets_the_lane_change():
    driver = ReferenceDriver(LEFT)
    driver(_obs(_debris(), speed=CHANGE_SPEED))
    assert driver.target == 3.5
    driver.reset()
    assert driver.target == 0.0 and driver.offset == 0.0 and driver.reacting_to == []


# --- 8. traffic vs. slow vehicles ---------------------------------------------------------------


@pytest.mark.parametrize("vis", [{}, {"brake_lights": "on"}])
def test_waits_behind_a_vehicle_stopped_in_traffic(vis):
    driver = ReferenceDriver(LEFT)
    assert _target_after(driver, _actor("queued", x=30.0, **vis), calls=5) == 0.0
    assert driver.offset == 0.0


def test_goes_around_a_slow_bicycle():
    bike = _actor("bike", x=30.0, vx=3.0, asset="bicycle", length=1.8, width=0.6)
    assert _target_after(ReferenceDriver(LEFT), bike) == 3.5
    # one riding at most a little slower than it wants to go is followed, not overtaken
    quick = _actor("bike", x=30.0, vx=8.0, asset="bicycle", length=1.8, width=0.6)
    assert _target_after(ReferenceDriver(LEFT), quick, calls=3) == 0.0
    # nor one that just slowed down to that speed: traffic that slows for a reason. It reads the
    # motion, not the brake lights (which may be broken, the paper's probe)
    driver = ReferenceDriver(LEFT)
    driver(Observation(t=0.0, dt=0.1, ego=_ego(), actors=(_actor("bike", x=30.0, vx=8.0, asset="bicycle",
                                                                  length=1.8, width=0.6),)))
    slowed = _actor("bike", x=30.8, vx=3.0, asset="bicycle", length=1.8, width=0.6, brake_lights="off")
    for k in range(1, 4):
        driver(Observation(t=0.1 * k, dt=0.1, ego=_ego(), actors=(slowed,)))
    assert driver.target == 0.0
    # brake lights alone (no slowing seen) do not make it traffic
    lit = _actor("bike", x=30.0, vx=3.0, asset="bicycle", length=1.8, width=0.6, brake_lights="on")
    assert _target_after(ReferenceDriver(LEFT), lit) == 3.5


# --- 9. moving off ------------------------------------------------------------------------------


def test_standing_at_a_red_light_it_holds_and_moves_off_on_green():
    assert _accel(_light("red", x=15.0), speed=0.0) <= 0.0
    assert _accel(_light("green", x=15.0), speed=0.0) > 1.0


def test_standing_it_waits_for_a_queued_car_within_reach_only():
    assert _accel(_actor("queued", x=20.0), speed=0.0) <= 0.0  # 15.4 m ahead, standing
    assert _accel(_actor("queued", x=50.0), speed=0.0) > 0.0  # 45.4 m: beyond start_hold
    assert _accel(_actor("queued", x=20.0, vx=3.0), speed=0.0) > 0.0  # moving off itself


# --- 10. what it reacted to ---------------------------------------------------------------------


def test_reacting_to_names_the_cause():
    driver = ReferenceDriver()
    driver(_obs(_light("red"), t=0.0))
    driver(_obs(_light("green"), t=0.1))
    assert driver.reacting_to == [(0.0, "light"), (0.1, None)]


def test_reacting_to_names_a_leader_only_when_it_binds():
    driver = ReferenceDriver()
    driver(_obs(_actor("lead", x=58.0, vx=15.0)))  # far ahead, pulling away: no reaction
    driver(_obs(_actor("lead", x=20.0), t=0.1))
    assert driver.reacting_to == [(0.0, None), (0.1, "lead")]


def test_reacting_to_names_a_hazard_and_what_a_lane_change_goes_around():
    hazard = ReferenceDriver()
    hazard(_obs(_debris(x=20.0, y=-1.75 - 3.25, name="cone")))
    assert hazard.reacting_to == [(0.0, "cone")]
    changer = ReferenceDriver(LEFT)
    changer(_obs(_debris(name="box"), speed=CHANGE_SPEED))
    assert changer.target == 3.5 and changer.reacting_to == [(0.0, "box")]


def test_stops_at_a_dark_light_then_goes_on_after_standing_there():
    driver = ReferenceDriver()
    dark = _light("off", x=12.0)  # the stop line 2 m before it, 7.7 m from its front bumper
    assert driver(_obs(dark)).acceleration < -3.0  # an all-way stop: brakes for it
    assert _accel(_light("green", x=12.0)) == pytest.approx(0.0, abs=1e-9)  # a working green: no
    for k in range(19):  # stands 1.9 s at the line: still held
        assert driver(_obs(dark, x=7.0, speed=0.0, t=k / 10)).acceleration < 0.0
    assert driver(_obs(dark, x=7.0, speed=0.0, t=2.0)).acceleration > 0.5  # 2 s: it moves off
    assert driver(_obs(dark, x=8.0, speed=2.0, t=2.5)).acceleration > 0.5  # and keeps going
    assert driver.reacting_to[0] == (0.0, "light")
