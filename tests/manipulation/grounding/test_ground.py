"""Grounding: model answers are validated data; rules fill gaps; infeasible is reported."""

from __future__ import annotations

import pytest

from regen.core import Behavior, CausePath, PathEntity
from regen.errors import (
    CacheMissError,
    MissingAPIKeyError,
    ModelFileError,
    ProviderResponseError,
    ProviderUnreachableError,
)
from regen.manipulation.grounding.answers import GroundAnswer, PlacementChoice
from regen.manipulation.grounding.ground import ground_path

pytest.importorskip("ortools")


def _path(reward: str, text: str, events: list[str], assets: list[str]) -> CausePath:
    return CausePath(behavior=Behavior(text=text, domain="manipulation", params={"reward": reward}),
                     events=[*events, text], entities=[PathEntity(asset=a, event=events[0]) for a in assets])


def _llm(tmp_path, *answers):
    llm_mod = pytest.importorskip("regen.llm")
    testing = pytest.importorskip("regen.llm.testing")
    return llm_mod.LLM(testing.QueuedProvider(list(answers)), cache=tmp_path / "cache.sqlite")


def test_rules_put_the_pet_outside_the_door():
    sc = ground_path(_path("open_door", "the robot opens the door", ["the pet wants to come in"], ["pet"]))
    assert sc.solver.status in ("optimal", "feasible")
    assert sc.entity("pet1").behavior_params == {"relation": "outside", "reference": "door1"}
    states = {(s.actor, s.name): s for s in sc.fsm.states}
    assert states[("pet1", "placed")].all_of[0].name == "outside"
    assert [c.name for c in states[("robot", "task_done")].all_of] == ["joint_open"]
    assert len(sc.fsm.stages) == 3


def test_model_choice_is_used_and_bad_ones_fall_back(tmp_path):
    answer = GroundAnswer(narrative="The plant needs water, so the robot opens the tap.",
                          placements=[PlacementChoice(object="plant1", relation="near", reference="faucet1"),
                                      PlacementChoice(object="cup1", relation="levitate", reference="table")])
    llm = _llm(tmp_path, answer)
    sc = ground_path(_path("adjust_faucet", "the robot turns the faucet handle", ["the plant is dry"],
                           ["plant", "cup"]), llm)
    assert sc.narrative.startswith("The plant needs water")
    assert sc.entity("plant1").behavior_params["relation"] == "near"
    assert sc.entity("cup1").behavior_params["relation"] == "in"  # the rule for a cup at a sink
    assert any("levitate" in r for r in sc.fallbacks)
    assert not any("levitate" in r for r in sc.solver.relaxations)


def test_impossible_placement_reported_without_relaxation():
    sc = ground_path(_path("open_cabinet", "the robot opens the cabinet door", ["guests arrive"], ["cup"]),
                     relax=False, choices={"cup1": ("in", "table")})
    assert sc.solver.status == "infeasible"
    assert "table has no interior that can host objects" in sc.solver.conflicts[0]


def test_impossible_placement_is_relaxed_and_said(tmp_path):
    sc = ground_path(_path("open_cabinet", "the robot opens the cabinet door", ["guests arrive"], ["cup"]),
                     choices={"cup1": ("in", "table")})
    assert sc.solver.status in ("optimal", "feasible")
    assert sc.entity("cup1").behavior_params["relation"] != "in" or \
        sc.entity("cup1").behavior_params["reference"] != "table"
    assert any("table has no interior" in r for r in sc.solver.relaxations)
    assert sc.fallbacks == []  # no model was asked: nothing replaced a model answer


def test_path_entity_becomes_the_retrieved_item():
    sc = ground_path(_path("retrieve_from_fridge", "the robot retrieves an item from the fridge",
                           ["someone is thirsty"], ["bottle", "cup"]))
    roles = {e.name: e.properties.get("role") for e in sc.entities}
    assert roles.get("bottle_item") == "item"
    done = sc.fsm.state("robot", "task_done").all_of
    assert any(c.name == "holding" and c.args == ["robot", "bottle_item"] for c in done)


def _pet_at_door() -> CausePath:
    return _path("open_door", "the robot opens the door", ["the pet wants to come in"], ["pet"])


def test_malformed_answer_falls_back_to_the_rules_and_says_so(tmp_path):
    llm = _llm(tmp_path, "not json", '{"narrative": 3}', "still not json")  # first try + 2 re-asks
    sc = ground_path(_pet_at_door(), llm)
    assert sc.entity("pet1").behavior_params == {"relation": "outside", "reference": "door1"}
    assert len(sc.fallbacks) == 1 and "model answer unusable" in sc.fallbacks[0]
    assert "used the rules" in sc.fallbacks[0]
    assert sc.solver.relaxations == []  # placement changes only
    assert llm.provider.answers == []  # all three answers were spent


def test_objects_the_model_left_out_are_said(tmp_path):
    llm = _llm(tmp_path, GroundAnswer(narrative="The pet scratches at the door.", placements=[]))
    sc = ground_path(_pet_at_door(), llm)
    assert sc.narrative == "The pet scratches at the door."
    assert sc.fallbacks == ["model gave no placement for pet1; used the rules"]


def test_replay_cache_miss_propagates(tmp_path):
    from regen.llm import LLM
    from regen.llm.testing import QueuedProvider

    cache = tmp_path / "empty.sqlite"
    cache.touch()
    llm = LLM(QueuedProvider([]), cache=cache, replay=True)
    with pytest.raises(CacheMissError, match="replay mode"):
        ground_path(_pet_at_door(), llm)


@pytest.mark.parametrize("error", [ProviderUnreachableError, ProviderResponseError,
                                   MissingAPIKeyError, ModelFileError])
def test_provider_errors_propagate_unchanged(tmp_path, error):
    from regen.llm import LLM
    from regen.llm.testing import FunctionProvider

    raised = error("the provider failed")

    def fail(messages):
        raise raised

    with pytest.raises(error) as caught:
        ground_path(_pet_at_door(), LLM(FunctionProvider(fail), cache=tmp_path / "c.sqlite"))
    assert caught.value is raised


@pytest.mark.parametrize("reward,text,cause,asset,relation", [
    ("open_door", "the robot opens the door", "a visitor rings and waits at the door", "visitor", "outside"),
    ("carry_bucket", "the robot carries the bucket", "juice was spilled on the floor", "spill", "near"),
    ("turn_oven_knob", "the robot turns the oven knob", "the ingredients for a cake are ready", "ingredients", "on"),
])
def test_context_assets_are_placed_with_a_cause_state(reward, text, cause, asset, relation):
    sc = ground_path(_path(reward, text, [cause], [asset]))
    assert sc.solver.status == "optimal" and not sc.solver.relaxations
    e = sc.entity(f"{asset}1")
    assert e.properties["role"] == "context" and e.behavior_params["relation"] == relation
    placed = next(s for s in sc.fsm.states if s.actor == e.name)
    assert placed.cause and placed.all_of[0].name == relation
    assert sc.fsm.stages[0].conditions[0].actor == e.name  # it holds before the robot acts


def test_what_a_carried_bucket_is_for_stays_where_the_bucket_leaves():
    # relative to the bucket, the spill would move away with it and its cause state end false
    sc = ground_path(_path("carry_bucket", "the robot carries the bucket", ["mopping the floor"], ["mop", "spill"]))
    refs = {e.name: e.behavior_params["reference"] for e in sc.entities if e.properties.get("role") == "context"}
    assert refs == {"mop1": "table", "spill1": "table"}
