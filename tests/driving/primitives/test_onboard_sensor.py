def test_jammed_gnss_rides_on_the_ego_and_degrades_before_the_event(ground):
    sc, t, plans = ground("stop_abruptly", "gnss", gnss_signal="jammed")
    p = plans["gnss1"]
    assert p.kind == "sensor" and p.cls == "" and p.attach_to == "ego"
    assert (p.x, p.y) == plans["ego"].route[0] and p.heading == plans["ego"].heading
    degrade = sc.parameters["gnss1"]["t"]
    assert p.states["gnss_signal"] == [(0.0, "nominal"), (degrade, "jammed")]
    assert [s.name for s in sc.fsm.states if s.actor == "gnss1"] == ["nominal", "degraded"]
