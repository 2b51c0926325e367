"""A narrative's state words against the states the run showed (verify.claims.check_states),
with the driving asset database."""

from __future__ import annotations

import pytest

from regen.verify.claims import check_states


@pytest.fixture(scope="module")
def db():
    from regen.driving.assets import database

    return database()


LIGHT = [("traffic_light1", "traffic_light"), ("adult1", "adult")]


def test_a_red_light_the_run_shows_green_is_marked_as_the_model_s_claim(db):
    text = "A pedestrian steps into the road. The traffic light is red, so the ego stops."
    (note,) = check_states(text, LIGHT, {"traffic_light1": {"light_state": {"green"}}}, db)
    assert "'The traffic light is red, so the ego stops.'" in note and "('red light')" not in note
    assert "traffic_light1 has light_state = green" in note


def test_a_state_the_run_showed_at_some_point_is_no_false_claim(db):
    shown = {"traffic_light1": {"light_state": {"green", "yellow", "red", "turns_red"}}}
    assert check_states("The traffic light turns red as the ego comes close.", LIGHT, shown, db) == []


def test_a_negated_state_claims_nothing_and_a_state_nobody_can_have_is_not_checked(db):
    shown = {"traffic_light1": {"light_state": {"green"}}}
    assert check_states("The light is not red.", LIGHT, shown, db) == []
    assert check_states("A siren wails somewhere.", LIGHT, shown, db) == []  # nobody here has a siren


def test_brake_lights_the_run_never_lit_are_marked(db):
    cast = [("sedan1", "sedan")]
    text = "The car ahead brakes with its brake lights on."
    (note,) = check_states(text, cast, {"sedan1": {"brake_lights": {"broken"}}}, db)
    assert "sedan1 has brake_lights = broken" in note
    assert check_states(text, cast, {"sedan1": {"brake_lights": {"off", "on"}}}, db) == []
