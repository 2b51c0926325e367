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


def test_the_same_choice_gets_the_same_answer_model_and_another_choice_another():
    """A choice asked again (an expansion asks for the same few) gets the very classes made the
    first time, so their schemas are made once; other values make other classes."""
    from regen.llm.client import json_schema_of

    first, again = choice_models(OPTIONS, CHOICES), choice_models(OPTIONS, CHOICES)
    assert [id(m) for m in first] == [id(m) for m in again]
    assert [json_schema_of(m) for m in first] == [m.model_json_schema() for m in again]
    fewer = {p: (t, v[:1]) for p, (t, v) in OPTIONS.items()}
    other = choice_models(fewer, None)
    assert len(other) == 1 and all(other[0] is not m for m in first)
    assert all(len(get_args(f.annotation)) == 1 for f in other[0].model_fields.values())
