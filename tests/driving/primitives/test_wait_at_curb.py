def test_a_person_stands_at_the_curb_ahead_of_the_egos_event(ground):
    sc, t, plans = ground("slow_down", "adult", behavior="wait_at_curb", start_location="roadside_ahead")
    p = plans["adult1"]
    assert not p.dynamic and p.cls == "Pedestrian"
    assert abs(p.y) > t.frame.lanes_same_direction * t.frame.lane_width  # beyond the lanes: on the sidewalk
    assert t.s_event - 4.0 <= p.x - t.frame.ox <= t.s_event + 35.0 or p.x > t.s_event - 4.0
    cause = next(s for s in sc.fsm.states if s.actor == "adult1" and s.cause)
    assert {c.name for c in cause.all_of} == {"stopped", "on_sidewalk", "ahead_of", "close_to"}
