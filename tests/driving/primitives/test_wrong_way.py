import math

import pytest


def test_a_car_drives_at_the_ego_in_its_lane_and_stops_ahead_of_it(ground):
    sc, t, plans = ground("stop_abruptly", "sedan", behavior="wrong_way", start_location="ahead_same_lane")
    p, prm = plans["sedan1"], sc.parameters["sedan1"]
    assert p.y == pytest.approx(t.frame.lane_d(t.ego_lane))
    assert math.cos(p.heading - t.frame.heading) == pytest.approx(-1.0)  # facing the ego
    assert p.route[-1][0] < p.route[0][0]  # it drives towards -s, at the ego
    assert t.t_event + 0.3 <= prm["t"] <= t.t_event + 1.5
    stop = prm["s"] - prm["v"] * prm["t"] - prm["v"] ** 2 / 13.6 - 0.1 * prm["v"]
    assert stop - (p.length + 4.6) / 2 > t.s_end  # comes to rest ahead of the stopped ego


def test_an_ego_that_does_not_stop_cannot_meet_it():
    from regen.driving.assets import database
    from regen.driving.grounding.placement import solve
    from regen.driving.world.actors import ActorSpec
    from regen.driving.world.egos import EGO_TEMPLATES

    actor = ActorSpec(name="sedan1", asset="sedan", primitive="wrong_way", location="ahead_same_lane",
                      speed_class="moderate", size=tuple(database().assets["sedan"].size))
    sol = solve(EGO_TEMPLATES["slow_down"], [actor])
    assert sol.report.status == "infeasible"
    assert any("meets only an ego that stops" in c for c in sol.report.conflicts)
