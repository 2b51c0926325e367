import pytest


def test_an_emergency_vehicle_crosses_the_junction_with_its_siren_on(ground):
    sc, t, plans = ground("stop_in_intersection", "ambulance", behavior="pass_through",
                          start_location="junction_cross_street")
    p, prm = plans["ambulance1"], sc.parameters["ambulance1"]
    assert p.heading == pytest.approx(1.5708, abs=1e-3) and p.route[-1][1] > 0  # north across the ego's road
    enters = prm["d0"] / prm["v"]  # [s] to the junction's edge
    assert t.t_event - 1.2 - 0.1 <= enters <= t.t_event + 0.8 + 0.1
    assert sc.entity("ambulance1").properties["siren"] == "on"  # implied by the motion
    assert set(v for _, v in p.states["siren"]) == {"on"}
    cause = next(s for s in sc.fsm.states if s.actor == "ambulance1" and s.cause)
    assert {c.name for c in cause.all_of} == {"siren_on", "in_junction", "moving"}


def test_a_graph_that_turns_its_siren_off_cannot_be_honored():
    from regen.driving.assets import database
    from regen.driving.grounding.rules import check_roles
    from regen.driving.world.actors import RoleChoice

    role = RoleChoice(name="ambulance1", asset="ambulance", primitive="pass_through",
                      location="junction_cross_street", speed_class="fast", properties={"siren": "off"})
    (problem,) = check_roles([role], database())
    assert "siren = 'off' cannot be honored: pass_through means siren = on" in problem
