"""The graph is offered only the start places some map of the ego's behavior can host, so a
model's choice cannot make a cause ungroundable by a place the ego never meets."""

from __future__ import annotations

from regen import domains
from regen.core.behavior import Behavior
from regen.driving.grounding.rules import can_host
from regen.driving.world.egos import template_for


def _starts(ego: str, asset: str = "ambulance") -> dict[str, list[str]]:
    backend = domains.make("driving")
    prop, choices = backend.property_choices(asset, Behavior(text="x", domain="driving",
                                                              params={"ego_template": ego}))
    assert prop == "behavior"
    return {b: allowed["start_location"] for b, allowed in choices.items()}


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
