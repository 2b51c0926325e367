from __future__ import annotations

import json

import pytest
from pydantic import ValidationError

from regen.core import (
    FSM,
    AbstractState,
    ActorTrack,
    Behavior,
    CausePath,
    Entity,
    PathEntity,
    PredicateCall,
    Scenario,
    ScenarioGraph,
    Stage,
    StateRef,
    Trace,
    Verdict,
)
from regen.core.behavior import make_behavior
from regen.core.graph import Decision, Node, node_id
from regen.core.verdict import StageResult
from regen.errors import GraphCycleError, GraphError


def _behavior() -> Behavior:
    return Behavior(text="the ego-vehicle stops abruptly", domain="driving", params={"ego_template": "stop_abruptly"})


def _graph() -> ScenarioGraph:
    g = ScenarioGraph.start(_behavior())
    amb = g.add_node(Node(id=node_id("event", "ambulance approaches from behind"), kind="event",
                          label="ambulance approaches from behind", status="accepted", depth=1,
                          history=[Decision(action="proposed", by="model", call_id="k1")]))
    g.add_edge(amb.id, g.root, decision=Decision(action="accepted", by="model", reason="yield"))
    ent = g.add_node(Node(id=node_id("entity", "ambulance", amb.id), kind="entity", label="ambulance",
                          asset="ambulance", status="accepted"))
    g.add_edge(ent.id, amb.id)
    prop = g.add_node(Node(id=node_id("property", "siren=on", ent.id), kind="property",
                           label="siren = on", property="siren", value="on", status="accepted"))
    g.add_edge(prop.id, ent.id)
    rej = g.add_node(Node(id=node_id("event", "a jaywalker in another city"), kind="event",
                          label="a jaywalker in another city", status="rejected", depth=1))
    g.add_edge(rej.id, g.root, status="rejected",
               decision=Decision(action="rejected", by="model", reason="not plausible"))
    return g


def _scenario() -> Scenario:
    fsm = FSM(
        states=[
            AbstractState(name="Ambulance Approaching", actor="ambulance1",
                          all_of=[PredicateCall(name="moving", args=["ambulance1"]),
                                  PredicateCall(name="close_to", args=["ambulance1", "ego"],
                                                params={"distance": 30.0})]),
            AbstractState(name="Ego Stopped", actor="ego",
                          all_of=[PredicateCall(name="stopped", args=["ego"])]),
        ],
        stages=[Stage(conditions=[StateRef(actor="ambulance1", state="Ambulance Approaching")]),
                Stage(conditions=[StateRef(actor="ego", state="Ego Stopped")])],
    )
    return Scenario(id="s1", domain="driving", behavior=_behavior(),
                    causal_graph=["ambulance approaches from behind", "the ego-vehicle stops abruptly"],
                    narrative="An ambulance approaches; the ego stops.",
                    entities=[Entity(name="ego", asset="ego", kind="ego"),
                              Entity(name="ambulance1", asset="ambulance", properties={"siren": "on"},
                                     behavior="drive_forward", behavior_params={"speed": 14.0})],
                    fsm=fsm, parameters={"ambulance1": {"lane": 0, "s0": -25.0}},
                    world={"map": "straight", "duration": 12.0})


def _trace() -> Trace:
    return Trace(dt=0.1, times=[0.0, 0.1], actors={
        "ego": ActorTrack(asset="ego", kind="ego", x=[0.0, 1.0], y=[0.0, 0.0], heading=[0.0, 0.0],
                          speed=[10.0, 9.0], states={"brake_lights": ["off", "on"]})})


@pytest.mark.parametrize("factory", [_behavior, _graph, _scenario, _trace,
                                     lambda: Verdict(feasible=True, status="verified", reason="ok",
                                                     stages=[StageResult(index=1, conditions=["a: b"],
                                                                         reached_at=1.5)])])
def test_json_round_trip_is_exact(factory) -> None:
    value = factory()
    text = value.model_dump_json()
    again = type(value).model_validate_json(text)
    assert again == value
    assert json.loads(again.model_dump_json()) == json.loads(text)


def test_cause_path_round_trip_and_stable_key() -> None:
    p = CausePath(behavior=_behavior(), events=["a", "b"],
                  entities=[PathEntity(asset="ambulance", event="a", properties={"siren": ["on"]})])
    again = CausePath.model_validate_json(p.model_dump_json())
    assert again == p and again.key == p.key
    assert CausePath(behavior=_behavior(), events=["c", "b"]).key != p.key


def test_adding_an_edge_that_closes_a_cycle_is_refused() -> None:
    g = _graph()
    cause = g.find("event", "ambulance approaches from behind")
    with pytest.raises(GraphCycleError, match="cyclic"):
        g.add_edge(g.root, cause.id)


def test_loading_a_cyclic_graph_is_refused_with_the_cycle_named() -> None:
    data = json.loads(_graph().model_dump_json())
    cause = node_id("event", "ambulance approaches from behind")
    data["edges"].append({"source": data["root"], "target": cause, "kind": "causes"})
    with pytest.raises(GraphCycleError, match="cycle.*ambulance approaches"):
        ScenarioGraph.model_validate(data)


def test_a_rejected_back_edge_is_not_a_cycle() -> None:
    g = _graph()
    cause = g.find("event", "ambulance approaches from behind")
    g.add_edge(g.root, cause.id, status="rejected")  # kept for the audit, not part of the DAG
    ScenarioGraph.model_validate_json(g.model_dump_json())


def test_edge_kinds_are_checked() -> None:
    g = _graph()
    ent = next(n for n in g.nodes.values() if n.kind == "entity")
    prop = next(n for n in g.nodes.values() if n.kind == "property")
    with pytest.raises(GraphError, match="no edge type"):
        g.add_edge(ent.id, prop.id)


def test_paths_keep_simulatable_chains_with_entities_and_properties() -> None:
    g = _graph()
    paths = g.paths()
    assert len(paths) == 1
    p = paths[0]
    assert p.events == ["ambulance approaches from behind", "the ego-vehicle stops abruptly"]
    assert p.entities[0].asset == "ambulance" and p.entities[0].properties == {"siren": ["on"]}


def test_paths_skip_events_without_entities() -> None:
    g = _graph()
    tree = g.add_node(Node(id=node_id("event", "a tree fell in front"), kind="event",
                           label="a tree fell in front", status="unsimulatable", depth=1))
    g.add_edge(tree.id, g.root)
    assert [p.events[0] for p in g.paths()] == ["ambulance approaches from behind"]


def test_scenario_rejects_unknown_actor_in_fsm() -> None:
    data = json.loads(_scenario().model_dump_json())
    data["fsm"]["states"][0]["all_of"][1]["args"] = ["ambulance1", "ghost"]
    with pytest.raises(ValidationError, match="unknown actor 'ghost'"):
        Scenario.model_validate(data)


def test_fsm_rejects_stage_naming_undefined_state() -> None:
    with pytest.raises(ValidationError, match="no abstract state defines"):
        FSM(states=[], stages=[Stage(conditions=[StateRef(actor="ego", state="Flying")])])


def test_trace_lengths_must_agree() -> None:
    with pytest.raises(ValidationError, match="speed has 1 values for 2 steps"):
        Trace(dt=0.1, times=[0.0, 0.1], actors={"ego": ActorTrack(asset="ego", x=[0, 1], y=[0, 0],
                                                                   speed=[1.0])})


@pytest.mark.parametrize("text", ["", "   \n\t "])
def test_empty_behavior_is_refused_with_advice(text: str) -> None:
    with pytest.raises(ValidationError, match="describe the robot behavior"):
        Behavior(text=text, domain="driving")


def test_unknown_domain_and_unknown_keys_are_refused() -> None:
    from regen.errors import ConfigError

    with pytest.raises(ValidationError):
        Behavior(text="x", domain="")
    with pytest.raises(ConfigError, match="unknown domain 'flying'; choose one of: driving, manipulation"):
        make_behavior("x", "flying")
    with pytest.raises(ValidationError):
        Behavior.model_validate({"text": "x", "domain": "driving", "txet": "typo"})


def test_variants_split_multi_valued_properties() -> None:
    p = CausePath(behavior=_behavior(), events=["a", "b"], entities=[
        PathEntity(asset="ambulance", event="a", properties={"siren": ["on"], "start_location": ["x", "y"]}),
        PathEntity(asset="sedan", event="a", properties={"target_speed": ["slow", "fast"]})])
    vs = p.variants(limit=3)
    assert len(vs) == 3
    assert [(v.entities[0].properties["start_location"], v.entities[1].properties["target_speed"]) for v in vs] == [
        (["x"], ["slow"]), (["x"], ["fast"]), (["y"], ["slow"])]
    assert all(v.entities[0].properties["siren"] == ["on"] for v in vs)
    assert p.entities[0].properties["start_location"] == ["x", "y"]  # the original is untouched
    single = CausePath(behavior=_behavior(), events=["a", "b"])
    assert single.variants() == [single]


def test_an_old_scenario_with_an_ego_kind_loads_with_one_word_for_the_robot():
    from regen.core.scenario import Entity

    old = Entity.model_validate({"name": "ego", "asset": "ego", "kind": "ego"})
    assert old.kind == "robot"
    with pytest.raises(ValueError):
        Entity.model_validate({"name": "x", "asset": "x", "kind": "pilot"})
