"""The graph is offered only the start places some map of the ego's behavior can host, so a
model's choice cannot make a cause ungroundable by a place the ego never meets."""

from __future__ import annotations

from regen import domains
from regen.core.behavior import Behavior
from regen.driving.grounding.rules import can_host
from regen.driving.world.egos import template_for


def _starts(ego: str, asset: str = "ambulance") -> dict[str, list[str]]:
    backend = domains.make("driving")
    choices = backend.property_choices(asset, Behavior(text="x", domain="driving",
                                                       params={"ego_template": ego}))
    assert choices.key == "behavior"
    return {b: sorted({x for alt in choices.alternatives(b) for x in alt["start_location"]})
            for b in choices.allowed}


def test_an_ego_changing_lanes_on_a_straight_road_is_offered_no_junction_place() -> None:
    lane = _starts("change_lane")
    assert "pass_through" not in lane  # a motion through a junction the ego never reaches
    assert not any(x.startswith("junction_") for places in lane.values() for x in places)
    stop = _starts("stop_abruptly")  # its road can be a junction map: junction places stay
    assert stop["pass_through"] == ["junction_cross_street"]


def test_can_host_follows_the_map_rules() -> None:
    lane, stop = template_for("x", "change_lane"), template_for("x", "stop_abruptly")
    assert not can_host(lane, "junction_corner") and can_host(stop, "junction_corner")
    assert can_host(lane, "behind_adjacent_lane")  # its road has a second lane
    assert not can_host(stop, "nowhere_known")


def test_a_lead_car_ahead_of_an_ego_that_stops_is_offered_no_speed_the_solver_cannot_place() -> None:
    """'the front car with broken brake lights stops' was chosen slow ahead of an ego at 10 m/s:
    unsatisfiable. The (start, speed) pairs offered are the ones the placement model solves."""
    from regen.contract import PropertyChoices
    from regen.driving.grounding.placement import solve
    from regen.driving.world.actors import ActorSpec
    from regen.driving.world.egos import template_for
    from regen.expand.choices import choice_models

    backend = domains.make("driving")
    choices = backend.property_choices("sedan", Behavior(text="x", domain="driving",
                                                         params={"ego_template": "stop_abruptly"}))
    alts = choices.allowed["drive_forward"]
    assert isinstance(alts, list)
    speeds = {x: alt["target_speed"] for alt in alts for x in alt["start_location"]}
    assert "slow" not in speeds["ahead_same_lane"] and "slow" in speeds["ahead_adjacent_lane"]
    t = template_for("x", "stop_abruptly")
    for x, sp in (("ahead_same_lane", "slow"), ("ahead_same_lane", "moderate")):
        solved = solve(t, [ActorSpec(name="a1", asset="sedan", primitive="drive_forward", location=x,
                                     speed_class=sp, properties={}, size=(4.6, 1.9, 1.5))])
        assert (solved.report.status in ("optimal", "feasible")) == (sp in speeds[x])
    # the judge's schema allows exactly these pairs
    options = {"behavior": ("", ["drive_forward"]), "start_location": ("", ["ahead_same_lane"]),
               "target_speed": ("", ["slow", "moderate", "fast"])}
    allowed = set()
    for model in choice_models(options, PropertyChoices("behavior", {"drive_forward": alts})):
        for sp in ("slow", "moderate", "fast"):
            try:
                model(behavior="drive_forward", start_location="ahead_same_lane", target_speed=sp)
                allowed.add(sp)
            except ValueError:
                pass
    assert allowed == set(speeds["ahead_same_lane"])


def test_a_motion_from_one_start_is_offered_only_the_speeds_the_solver_can_place() -> None:
    """The truck that 'stops abruptly' ahead of an ego at 10 m/s was chosen slow by the model:
    unsatisfiable. One start place is one group: its solvable speeds only."""
    backend = domains.make("driving")

    def speeds(ego: str, asset: str, motion: str) -> list[str]:
        choices = backend.property_choices(asset, Behavior(text="x", domain="driving",
                                                            params={"ego_template": ego}))
        return choices.allowed[motion]["target_speed"]

    assert speeds("stop_abruptly", "truck", "brake_ahead") == ["moderate", "fast"]
    assert speeds("slow_down", "sedan", "cut_in") == ["fast"]  # it overtakes an ego at 12 m/s
