from regen.driving.grounding.placement import solve
from regen.driving.world.actors import ActorSpec
from regen.driving.world.egos import EGO_TEMPLATES


def _actor(name, asset, primitive, location, speed_class, size):
    return ActorSpec(name=name, asset=asset, primitive=primitive, location=location,
                     speed_class=speed_class, size=size)


def test_pedestrian_crosses_ahead_of_where_the_ego_stops():
    t = EGO_TEMPLATES["stop_abruptly"]
    child = _actor("child1", "child", "cross_the_road", "roadside_ahead", "moderate", (0.4, 0.4, 1.2))
    sol = solve(t, [child])
    assert sol.report.status in ("optimal", "feasible")
    p = sol.params["child1"]
    assert p["s"] > t.s_end + 2.3  # path beyond the ego's front bumper at rest
    assert 1.2 <= p["v"] <= 1.8
    reach = 8.0 - 1.75 - 1.75  # sidewalk centre to the ego lane's near edge [m]
    assert t.t_event - 1.8 <= p["t"] + reach / p["v"] <= t.t_event - 0.2 + 0.05


def test_infeasible_model_names_only_the_conflict():
    t = EGO_TEMPLATES["stop_abruptly"]
    sol = solve(t, [
        _actor("sedan1", "sedan", "drive_forward", "ahead_same_lane", "slow", (4.6, 1.9, 1.5)),
        _actor("debris1", "debris", "stationary", "roadside_ahead", "slow", (1.0, 1.0, 0.3)),
    ])
    assert sol.report.status == "infeasible"
    assert sol.report.conflicts
    assert all(c.startswith("sedan1:") for c in sol.report.conflicts)
    assert any("as fast as the ego" in c for c in sol.report.conflicts)


def test_lights_and_sensors_only_get_a_switching_time():
    t = EGO_TEMPLATES["stop_abruptly"]
    gnss = _actor("gnss1", "gnss", "", "ahead_same_lane", "moderate", (0.0, 0.0, 0.0))
    light = _actor("light1", "traffic_light", "stationary", "junction_corner", "moderate", (0.3, 0.3, 4.0))
    sol = solve(t, [gnss, light])
    assert sol.report.status in ("optimal", "feasible")
    assert set(sol.params["gnss1"]) == set(sol.params["light1"]) == {"t"}
    assert t.t_event - 2.5 <= sol.params["gnss1"]["t"] <= t.t_event - 0.2


def test_no_actor_starts_on_an_arm_the_map_lacks():
    """A lead car for a stop after a right turn drives through the junction from the north: the
    T-junction has no north arm, so the frame starts at the junction there and the scenario
    goes to the four-way map (the car started on grass before)."""
    from driving_chains import FEASIBLE

    from regen.driving.grounding.rules import ground_rule_based
    from regen.driving.world.egos import EGO_TEMPLATES
    from regen.driving.world.maps import JUNCTION_RADIUS, geometry
    from regen.driving.world.placement import frame_start

    t = EGO_TEMPLATES["stop_after_turn"]
    assert t.map == "t_junction" and frame_start(t) == -JUNCTION_RADIUS
    assert frame_start(EGO_TEMPLATES["stop_abruptly"]) == -400.0
    sc = ground_rule_based(FEASIBLE["stop_after_turn"][2])
    assert sc.world["map"] == "four_way" and sc.solver.status in ("optimal", "feasible")
    g = geometry("t_junction")
    assert "north" not in g.arms


def _path(template: str, cause: str, asset: str, **properties: str):
    from regen.core.behavior import Behavior
    from regen.core.graph import CausePath, PathEntity

    return CausePath(behavior=Behavior(text=f"the ego-vehicle does {template}", domain="driving",
                                       params={"ego_template": template}),
                     events=[cause, f"the ego-vehicle does {template}"],
                     entities=[PathEntity(asset=asset, event=cause, properties={k: [v] for k, v in properties.items()})])


def test_a_speed_class_the_graph_left_open_is_changed_to_one_that_fits_and_said_so():
    from regen.driving.grounding.rules import ground_rule_based

    # a car cutting in in front of an ego at 12 m/s must be faster than it: 'moderate' is not
    sc = ground_rule_based(_path("slow_down", "a car cuts in front of the ego", "sedan", behavior="cut_in"))
    assert sc.solver.status in ("optimal", "feasible")
    assert sc.entity("sedan1").behavior_params["speed_class"] == "fast"
    assert sc.parameters["sedan1"]["v"] >= 14.0
    (note,) = [f for f in sc.fallbacks if "speed class" in f]
    assert "sedan1 moderate -> fast" in note and "faster than the ego" in note
    # the graph's own speed is never changed: the placement stays infeasible and says why
    fixed = ground_rule_based(_path("slow_down", "a car cuts in", "sedan", behavior="cut_in", target_speed="moderate"))
    assert fixed.solver.status == "infeasible" and not any("speed class" in f for f in fixed.fallbacks)
