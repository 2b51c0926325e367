"""Grounding: model answers are validated data; rules fill gaps; infeasible is reported."""

from __future__ import annotations

import pytest

from regen.core import Behavior, CausePath, PathEntity
from regen.manipulation.grounding import GroundAnswer, PlacementChoice, ground_path

pytest.importorskip("ortools")


def _path(reward: str, text: str, events: list[str], assets: list[str]) -> CausePath:
    return CausePath(behavior=Behavior(text=text, domain="manipulation", reward=reward),
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
    assert any("levitate" in r for r in sc.solver.relaxations)


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


def test_path_entity_becomes_the_retrieved_item():
    sc = ground_path(_path("retrieve_from_fridge", "the robot retrieves an item from the fridge",
                           ["someone is thirsty"], ["bottle", "cup"]))
    roles = {e.name: e.properties.get("role") for e in sc.entities}
    assert roles.get("bottle_item") == "item"
    done = sc.fsm.state("robot", "task_done").all_of
    assert any(c.name == "holding" and c.args == ["robot", "bottle_item"] for c in done)
