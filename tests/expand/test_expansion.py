from __future__ import annotations

import json
from pathlib import Path

from fake_expansion_model import ScriptedModel

from regen.core.behavior import Behavior
from regen.core.graph import ScenarioGraph
from regen.expand import Limits, expand
from regen.expand.run import run_expand
from regen.llm import LLM
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly"


def _behavior() -> Behavior:
    return Behavior(text=STOP, domain="driving")


def _model(**kw) -> ScriptedModel:
    base = dict(
        causes={STOP: ["a jaywalker walked in front", "an ambulance approaches from behind",
                       "a tree fell in front", "a jaywalker in another city"],
                "an ambulance approaches from behind": ["a traffic accident happened ahead"]},
        plausible={"a jaywalker in another city": False},
        entities={"a jaywalker walked in front": ["adult"],
                  "an ambulance approaches from behind": ["ambulance"],
                  "a traffic accident happened ahead": ["sedan", "police_car"],
                  "a tree fell in front": ["tree"]},
        values={},
        choose={"siren": ["on"], "behavior": ["drive_forward", "fly"],
                "start_location": ["behind_same_lane", "behind the moon"]},
    )
    base.update(kw)
    return ScriptedModel(**base)


def _run(model: ScriptedModel, limits: Limits | None = None, **kw) -> ScenarioGraph:
    return expand(_behavior(), LLM(FunctionProvider(model)), limits=limits or Limits(max_depth=2, max_causes=4, max_entities=3), **kw)


def test_full_expansion_builds_events_entities_properties() -> None:
    g = _run(_model())
    labels = {n.label: n for n in g.nodes.values()}
    assert labels["a jaywalker walked in front"].status == "accepted"
    assert labels["a traffic accident happened ahead"].depth == 2
    # implausible cause: kept, marked, with the model's reason
    rej = labels["a jaywalker in another city"]
    assert rej.status == "rejected" and rej.history[-1].reason == "because a jaywalker in another city"
    # an entity the database lacks: rejected by the database, the event unsimulatable (paper's tree)
    tree = labels["a tree fell in front"]
    assert tree.status == "unsimulatable" and "tree" in tree.history[-1].reason
    assert any(n.label == "tree" and n.status == "rejected" and n.history[0].by == "database"
               for n in g.nodes.values())
    # one value per property, from the database, consistent with the entity's behavior: the
    # ambulance drives from behind; the adult cannot drive, so it gets a behavior it has, and its
    # start location is one that behavior supports; a stationary entity gets no speed
    by_entity: dict[str, dict[str, list[str]]] = {}
    for n in g.nodes.values():
        if n.kind == "property" and n.status == "accepted":
            ent = g.nodes[next(e.target for e in g.edges if e.source == n.id)].label
            by_entity.setdefault(ent, {}).setdefault(n.property, []).append(n.value)
    amb = by_entity["ambulance"]
    assert amb["siren"] == ["on"] and amb["behavior"] == ["drive_forward"]
    assert amb["start_location"] == ["behind_same_lane"]
    adult = by_entity["adult"]
    assert adult["behavior"] == ["stationary"] and "target_speed" not in adult
    assert adult["start_location"][0] in ("ahead_same_lane", "behind_same_lane", "roadside_ahead")
    assert all(len(v) == 1 for props in by_entity.values() for v in props.values())
    # every accepted node's decision names the model call that made it
    # (or says the database decided it: an entity the event's words name)
    for n in g.nodes.values():
        if n.status == "accepted" and n.id != g.root:
            assert any(d.call_id or d.by == "database" for d in n.history), n.label


def test_paths_are_the_simulatable_chains() -> None:
    g = _run(_model())
    chains = sorted(tuple(p.events) for p in g.paths())
    assert chains == [
        ("a jaywalker walked in front", STOP),
        ("a traffic accident happened ahead", "an ambulance approaches from behind", STOP),
    ]
    amb = next(p for p in g.paths() if len(p.events) == 3)
    assert {e.asset for e in amb.entities} == {"sedan", "police_car", "ambulance"}
    ambulance = next(e for e in amb.entities if e.asset == "ambulance")
    assert ambulance.properties["siren"] == ["on"]


def test_graph_round_trips_through_json() -> None:
    g = _run(_model())
    assert ScenarioGraph.model_validate_json(g.model_dump_json()) == g


def test_max_depth_is_honoured() -> None:
    g = _run(_model(), Limits(max_depth=1))
    assert max(n.depth for n in g.nodes.values() if n.kind == "event") == 1
    assert "max_depth (1)" in g.stop_reason


def test_max_nodes_is_honoured() -> None:
    g = _run(_model(), Limits(max_depth=3, max_nodes=2))
    # the first layer accepts 3 causes at once; no second layer is expanded
    assert all(n.depth <= 1 for n in g.nodes.values() if n.kind == "event")
    assert "max_nodes (2)" in g.stop_reason


def test_max_calls_is_honoured() -> None:
    model = _model()
    llm = LLM(FunctionProvider(model))
    g = expand(_behavior(), llm, limits=Limits(max_depth=3, max_calls=2))
    assert "max_calls (2)" in g.stop_reason
    # the first source's causes are proposed and judged (one question each), then nothing more:
    # no entity calls after the budget ran out
    assert model.kinds[0] == "propose" and set(model.kinds[1:]) == {"judge"}
    assert g.paths() == []


def test_max_tokens_is_honoured() -> None:
    g = _run(_model(), Limits(max_depth=3, max_tokens=5))
    assert "max_tokens (5)" in g.stop_reason


def test_caller_stop_is_honoured() -> None:
    g = _run(_model(), should_stop=lambda: True)
    assert g.stop_reason == "stopped by the caller" and len(g.nodes) == 1


def test_interrupt_keeps_the_partial_graph(tmp_path: Path) -> None:
    model = _model()

    def interrupting(messages):
        if "The simulator can only create these entities" in messages[-1]["content"]:
            raise KeyboardInterrupt
        return model(messages)

    res = run_expand(_behavior(), LLM(FunctionProvider(interrupting)), tmp_path, limits=Limits(max_depth=1))
    assert "interrupted" in res.graph.stop_reason
    saved = ScenarioGraph.model_validate_json((tmp_path / "graph.json").read_text())
    assert {n.label for n in saved.events()} >= {"a jaywalker walked in front", STOP}


def test_user_candidates_and_duplicates_are_merged() -> None:
    model = _model(causes={STOP: ["A jaywalker walked in front.", "a jaywalker walked in front of the car"]})
    g = _run(model, Limits(max_depth=1), candidates=["a jaywalker walked in front", "debris on the road"])
    events = [n for n in g.events(None) if n.id != g.root]
    assert sorted(n.label for n in events) == ["A jaywalker walked in front", "debris on the road"]
    debris = next(n for n in events if n.label == "debris on the road")
    assert debris.history[0].by == "user"
    jay = next(n for n in events if n.label.startswith("A jaywalker"))
    assert any(d.action == "merged" for d in jay.history)


def test_a_cause_that_would_close_a_cycle_is_rejected() -> None:
    a, b = "a jaywalker walked in front", "the driver ahead braked hard"
    model = _model(causes={STOP: [a], a: [b], b: [a]}, entities={a: ["adult"], b: ["sedan"]})
    g = _run(model, Limits(max_depth=3))
    # b's proposed cause 'a' duplicates an existing event that b causes: a cycle, refused
    back = [e for e in g.edges if g.nodes[e.source].label == a and g.nodes[e.target].label == b]
    assert back and back[0].status == "rejected" and back[0].history[-1].reason == "would create a cycle"
    ScenarioGraph.model_validate_json(g.model_dump_json())  # still a DAG


def test_a_model_that_proposes_nothing_is_recorded() -> None:
    g = _run(_model(causes={}))
    root = g.nodes[g.root]
    assert root.history[-1].reason == "the model proposed no causes"
    assert g.paths() == []


def test_manipulation_uses_the_same_code() -> None:
    text = "the robot opens the door"
    model = ScriptedModel(causes={text: ["the pet wants to come in", "a dragon knocks"]},
                          plausible={"a dragon knocks": False},
                          entities={"the pet wants to come in": ["pet", "door"]},
                          values={"location": ["outside the door", "on the table"]},
                          choose={"location": ["outside the door"], "articulation": ["closed"]})
    g = expand(Behavior(text=text, domain="manipulation", params={"reward": "open_door"}), LLM(FunctionProvider(model)),
               limits=Limits(max_depth=1))
    (p,) = g.paths()
    assert {e.asset for e in p.entities} == {"pet"}  # the door is the robot's own task, no cause
    pet = next(e for e in p.entities if e.asset == "pet")
    assert pet.properties["location"] == ["outside the door"]  # a value the model proposed, then chose
    assert "values" in model.kinds  # free values (locations) are proposed by the model


def test_run_expand_writes_json_png_and_offline_html(tmp_path: Path) -> None:
    res = run_expand(_behavior(), LLM(FunctionProvider(_model())), tmp_path, limits=Limits(max_depth=2))
    page = (tmp_path / "graph.html").read_text()
    import re

    assert not re.search(r"""(src|href)\s*=\s*["']?https?:""", page)  # nothing fetched from a network
    assert json.loads((tmp_path / "graph.json").read_text())["root"] == res.graph.root
    from PIL import Image

    img = Image.open(tmp_path / "graph.png")
    assert img.width > 600 and img.height > 300


def test_hostile_labels_are_escaped_in_html(tmp_path: Path) -> None:
    evil = "</script><script>alert(1)</script>"
    model = _model(causes={STOP: [evil]}, entities={evil: ["adult"]})
    run_expand(_behavior(), LLM(FunctionProvider(model)), tmp_path, limits=Limits(max_depth=1))
    page = (tmp_path / "graph.html").read_text()
    assert "<script>alert(1)" not in page
    assert page.count("<script>") == 1


def test_entity_aliases_resolve_to_database_assets() -> None:
    model = _model(entities={"a jaywalker walked in front": ["pedestrian"],
                             "an ambulance approaches from behind": ["emergency vehicle"]})
    g = _run(model, Limits(max_depth=1))
    assets = {n.asset for n in g.nodes.values() if n.kind == "entity" and n.status == "accepted"}
    assert {"adult", "ambulance"} <= assets


def test_the_domain_is_looked_up_once_not_at_every_call(monkeypatch) -> None:
    # the backend the caller has travels down to every proposal and judgement: following one
    # behavior through expansion never goes back to the registry, and the graph is the same
    from regen import domains
    from regen.driving.backend import DrivingBackend

    expected = _run(_model())
    lookups: list[str] = []
    real = domains.backend_class
    monkeypatch.setattr(domains, "backend_class", lambda name: lookups.append(name) or real(name))
    g = _run(_model(), backend=DrivingBackend())
    assert lookups == []
    assert g.model_dump(exclude={"created"}) == expected.model_dump(exclude={"created"})
    _run(_model())  # by name: one look-up for the whole expansion
    assert lookups == ["driving"]
