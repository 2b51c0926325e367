"""A key value the domain cannot simulate around the ego (seen: a cyclist given 'turn_right'
from the oncoming lane for an ego that stops after its own turn, past the junction) is told to
the model, which is asked once more; its new, possible choice is the graph's."""

from __future__ import annotations

import json

from regen import domains
from regen.core.behavior import Behavior
from regen.expand import properties
from regen.llm import LLM
from regen.llm.testing import FunctionProvider

AFTER_TURN = Behavior(text="the ego-vehicle stops abruptly right after turning right", domain="driving",
                      params={"ego_template": "stop_after_turn"})
BAD = {"role": "rides too close", "choice": {"behavior": "turn_right", "start_location": "oncoming_lane",
                                            "target_speed": "fast"}}
GOOD = {"role": "rides too close", "choice": {"behavior": "drive_forward", "start_location": "oncoming_lane",
                                             "target_speed": "fast"}}


def _select(answers: list[dict], tmp_path):
    prompts: list[str] = []

    def answer(messages):
        prompts.append(messages[-1]["content"])
        return json.dumps(answers[min(len(prompts), len(answers)) - 1])

    backend = domains.make("driving")
    db = backend.database()
    llm = LLM(FunctionProvider(answer), cache=tmp_path / "cache.sqlite")
    options = properties.property_options(db, "bicycle", {})
    judged, _ = properties.select_properties(
        llm, "driving", ["A cyclist is riding too close to the vehicle", AFTER_TURN.text],
        "A cyclist is riding too close to the vehicle", "bicycle", options,
        backend.property_choices("bicycle", AFTER_TURN))
    return judged, prompts


def test_an_impossible_behavior_is_refused_and_asked_again(tmp_path) -> None:
    judged, prompts = _select([BAD, GOOD], tmp_path)
    assert list(judged["behavior"].accepted) == ["drive_forward"]
    assert len(prompts) == 2 and "cannot happen" not in prompts[0]
    assert ("Your last choice, behavior = turn_right, cannot happen around the ego-vehicle here; choose "
            "behavior from: stationary | drive_forward | cross_the_road") in prompts[1]


def test_the_second_answer_may_only_name_a_possible_behavior(tmp_path) -> None:
    """The model that names the impossible behavior again is held to the possible ones by the
    second schema: its answer is re-asked with the error, and a possible one is kept."""
    judged, prompts = _select([BAD, BAD, GOOD], tmp_path)
    assert list(judged["behavior"].accepted) == ["drive_forward"] and len(prompts) == 3


def test_a_possible_behavior_is_asked_once(tmp_path) -> None:
    judged, prompts = _select([GOOD], tmp_path)
    assert list(judged["behavior"].accepted) == ["drive_forward"] and len(prompts) == 1
