"""The search space: the single edits of a scenario (database values, removals, the graph's other
causes), their order, which pairs are compatible, and stable candidate ids."""

from __future__ import annotations

import pytest
from driving_chains import FEASIBLE

from regen import domains
from regen.core.graph import Node, ScenarioGraph, node_id
from regen.falsify.space import candidate_id, canonical, compatible, root_causes, single_edits
from regen.whatif import Edit

CHILD_PATH = FEASIBLE["stop_abruptly"][0]  # a child runs across the road


@pytest.fixture(scope="module")
def child():
    from regen.driving.grounding.rules import ground_rule_based

    return ground_rule_based(CHILD_PATH)


def test_single_edits_cover_the_cast_and_skip_what_it_has_now(child):
    db = domains.make("driving").database()
    edits = single_edits(child, CHILD_PATH, db, ["a road worker crosses the road", "the weather is nice"],
                         robot=("ego-vehicle",))
    words = [e.describe() for e in edits]
    assert words[:3] == ["add cause 'a road worker crosses the road'", "remove child1",
                         "set child1.behavior = stationary"]
    assert "add cause 'the weather is nice'" not in words  # names no asset: never a candidate
    sets = [e for e in edits if e.op == "set"]
    for prop in ("behavior", "start_location", "target_speed"):  # every other value, as ask_edits offers
        allowed = set(db.property_candidates("child", prop))
        assert {e.value for e in sets if e.property == prop} < allowed
    now = {("behavior", "cross_the_road"), ("start_location", "roadside_ahead"), ("target_speed", "moderate")}
    assert not {(e.property, e.value) for e in sets} & now  # never the value it has
    assert len(words) == len(set(words))
    again = single_edits(child, CHILD_PATH, db, ["a road worker crosses the road"], robot=("ego-vehicle",))
    assert [e.describe() for e in again] == [w for w in words if "weather" not in w]  # deterministic


def test_the_graph_s_other_root_causes_are_the_additions():
    g = ScenarioGraph.start(CHILD_PATH.behavior)
    ids = {}
    for label in ("a child runs across the road", "a road worker crosses the road", "a ball rolls out",
                  "the child chases a ball"):
        ids[label] = g.add_node(Node(id=node_id("event", label), kind="event", label=label, status="accepted")).id
    g.add_node(Node(id=node_id("event", "a dog barks"), kind="event", label="a dog barks", status="rejected"))
    for label in ("a child runs across the road", "a road worker crosses the road"):
        g.add_edge(ids[label], g.root)
    g.add_edge(ids["a ball rolls out"], ids["the child chases a ball"])
    g.add_edge(ids["the child chases a ball"], g.root)
    assert root_causes(g, CHILD_PATH.events) == ["a ball rolls out", "a road worker crosses the road"]
    assert root_causes(None, CHILD_PATH.events) == []


def test_pairs_touch_different_things():
    speed = Edit(op="set", entity="child1", property="target_speed", value="fast")
    slow = Edit(op="set", entity="child1", property="target_speed", value="slow")
    place = Edit(op="set", entity="child1", property="start_location", value="crosswalk_ahead")
    gone = Edit(op="remove", entity="child1")
    other = Edit(op="remove", entity="sedan1")
    add = Edit(op="add", text="a cyclist rides ahead")
    assert compatible(speed, place) and compatible(gone, other) and compatible(add, gone)
    assert not compatible(speed, slow) and not compatible(speed, gone) and not compatible(add, add)


def test_a_candidate_id_is_stable_and_ignores_the_order_of_its_edits():
    a = Edit(op="remove", entity="child1")
    b = Edit(op="add", text="a cyclist rides ahead")
    assert candidate_id("01-x", [a, b]) == candidate_id("01-x", [b, a]) == candidate_id("01-x", [b, a, b])
    assert candidate_id("01-x", [a]) != candidate_id("02-y", [a]) != candidate_id("01-x", [b])
    assert len(candidate_id("01-x", [a])) == 10 and canonical([a, b]) == canonical([b, a])
