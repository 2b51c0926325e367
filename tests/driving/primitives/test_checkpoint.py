def test_a_police_car_stands_in_the_egos_lane_beyond_its_stop_with_lights_on(ground):
    sc, t, plans = ground("stop_abruptly", "police_car", behavior="checkpoint", start_location="ahead_same_lane")
    p = plans["police_car1"]
    assert not p.dynamic and p.y == t.frame.lane_d(t.ego_lane) and p.x > t.s_end
    assert set(v for _, v in p.states["siren"]) == {"on"}
    cause = next(s for s in sc.fsm.states if s.actor == "police_car1" and s.cause)
    assert {c.name for c in cause.all_of} == {"stopped", "siren_on", "same_lane", "ahead_of"}
