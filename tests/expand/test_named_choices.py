"""A state the event's words name rules out the key values that cannot have it: 'a slow
tractor-trailer drives ahead' is no lead that brakes hard (that one only drives moderate or
fast); where no key value can have it, the choices stay what they were."""

from __future__ import annotations

from typing import get_args

from regen.contract import PropertyChoices
from regen.expand.choices import choice_models

CHOICES = PropertyChoices("behavior", {
    "brake_ahead": {"target_speed": ["moderate", "fast"], "start_location": ["ahead_same_lane"]},
    "drive_forward": [{"target_speed": ["slow"], "start_location": ["ahead_same_lane"]},
                      {"target_speed": ["moderate", "fast"], "start_location": ["adjacent_lane"]}],
    "stationary": {"start_location": ["roadside_ahead"]},
})
OPTIONS = {"behavior": ("motion", ["brake_ahead", "drive_forward", "stationary"]),
           "target_speed": ("speed", ["slow"]),  # the words named slow: the only offer
           "start_location": ("start", ["ahead_same_lane", "adjacent_lane", "roadside_ahead"])}


def _keys(models) -> list[str]:
    return [get_args(m.model_fields["behavior"].annotation)[0] for m in models]


def test_a_named_state_drops_the_key_values_that_cannot_have_it() -> None:
    models = choice_models(OPTIONS, CHOICES, frozenset({"target_speed"}))
    assert _keys(models) == ["drive_forward"]
    (m,) = models
    assert get_args(m.model_fields["start_location"].annotation) == ("ahead_same_lane",)


def test_without_a_named_state_the_models_values_are_kept_as_before() -> None:
    assert _keys(choice_models(OPTIONS, CHOICES)) == ["brake_ahead", "drive_forward", "stationary"]


def test_where_no_key_value_can_have_the_named_state_nothing_is_dropped() -> None:
    options = {**OPTIONS, "behavior": ("motion", ["brake_ahead", "stationary"])}
    assert _keys(choice_models(options, CHOICES, frozenset({"target_speed"}))) == ["brake_ahead", "stationary"]
