"""Expansion driven by answers recorded from the real offline model (scripts/record_cassettes.py),
and one live expansion against the offline model (marker 'model')."""

from __future__ import annotations

from pathlib import Path

import pytest
from cassette_cases import EXPANSIONS

from regen.assets.database import database_of as domain_database
from regen.core.graph import ScenarioGraph
from regen.expand import Limits, expand
from regen.llm import LLM
from regen.llm.cache import CallCache

CASSETTES = Path(__file__).resolve().parents[1] / "data" / "cassettes"

CASES = EXPANSIONS  # recorded by scripts/record_cassettes.py from the same table
# words of the robot's own command, programming, sensing or mechanics: never an accepted cause
MECHANICAL = ("programmed", "commanded", "instructed", "the robot's", "robot detects", "robot senses")


def _check(graph: ScenarioGraph) -> None:
    db = domain_database(graph.behavior.domain)
    ScenarioGraph.model_validate_json(graph.model_dump_json())
    for n in graph.nodes.values():
        if n.kind == "entity" and n.status == "accepted":
            assert n.asset in db.assets
        if n.kind == "property" and n.status == "accepted":
            enumerated = db.properties[n.property].states
            if n.property != "behavior" and enumerated is not None:
                assert n.value in enumerated


@pytest.mark.parametrize("name", sorted(CASES))
def test_expansion_replays_recorded_offline_model_answers(name: str) -> None:
    cache = CallCache(None)
    cache.import_json(CASSETTES / f"{name}.json")
    llm = LLM("local", cache=cache, replay=True)  # the model is not loaded: every answer is cached
    behavior, limits = CASES[name]
    graph = expand(behavior, llm, limits=limits)
    assert llm.stats.total.model_calls == 0 and llm.stats.total.cache_hits > 0
    _check(graph)
    causes = [n for n in graph.events(None) if n.id != graph.root]
    assert causes, "the recorded model proposed causes"
    paths = graph.paths()
    accepted = [n.label for n in causes if n.status == "accepted"]
    if graph.behavior.domain == "manipulation":
        # no accepted cause restates the robot's own mechanics, whatever the small model proposed
        assert not [a for a in accepted if any(w in a.lower() for w in MECHANICAL)], accepted
    if name == "expand_manipulation":
        # asked who in the home needs it and why, the offline model proposes who comes or goes
        # through the door (the paper's kind: let the pet in, see the guest out)
        assert set(accepted) == {"a child needs to open the door to go outside",
                                 "a parent needs to open the door to get to the kitchen",
                                 "a guest needs to open the door to enter the home"}
        assert all(p.entities for p in paths) and len(paths) == 3
    if name == "expand_manipulation_faucet":
        # a need, not the robot's doing; the bare restatement "a parent needs to turn on the
        # faucet" is rejected by the judge, with its reason on the graph
        assert accepted == ["a child needs to wash their hands"] and len(paths) == 1
    if name == "expand_manipulation_lamp":
        assert set(accepted) == {"a child needs to turn on the lamp to read a book",
                                 "a guest needs to turn on the lamp to watch a movie"}
        assert len(paths) == 2
        # the graph took a desk lamp for the task's lamp: it starts off, as the task needs
        power = {n.value for n in graph.nodes.values() if n.kind == "property" and n.property == "power"
                 and n.status == "accepted"}
        assert power == {"off"}
    if name == "expand_driving":
        # the event's words name the light's state: it turns red as the ego comes near
        (light,) = [e for p in paths if "turns red" in p.events[0] for e in p.entities
                    if e.asset == "traffic_light"]
        assert light.properties["light_state"] == ["turns_red"]
    if name in ("expand_driving", "expand_manipulation"):
        assert paths, "at least one simulatable cause chain"
        for p in paths:
            assert p.events[-1] == behavior.text and p.entities


@pytest.mark.model
@pytest.mark.usefixtures("shared_cache")
def test_live_expansion_with_the_offline_model(tmp_path: Path) -> None:
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    behavior, _ = CASES["expand_driving"]
    llm = LLM("local", cache=tmp_path / "c.sqlite")
    graph = expand(behavior, llm, limits=Limits(max_depth=1, max_causes=2, max_entities=1))
    _check(graph)
    assert llm.stats.total.model_calls >= 2
    assert len(graph.nodes) > 1
