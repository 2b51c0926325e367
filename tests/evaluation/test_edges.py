"""Edge-construction accuracy with fake judges, the labeled file format and the bundled file."""

from __future__ import annotations

import json

import pytest

from regen.errors import ConfigError, LLMError
from regen.evaluation.edges import (
    KINDS,
    EdgeExample,
    bundled_edge_examples,
    evaluate_edges,
    load_edge_examples,
    metrics,
)


def ex(kind, source, cand, label, domain="driving", context=None):
    return EdgeExample(kind=kind, source=source, candidate=cand, label=label, domain=domain,
                       context=context)


EXAMPLES = [
    ex("event->event", "ego stops", "jaywalker in front", True),
    ex("event->event", "ego stops", "ambulance behind", True),
    ex("event->event", "ego stops", "jaywalker in another city", False),
    ex("event->event", "ego stops", "radio plays a song", False),
    ex("entity->event", "ambulance behind", "ambulance", True),
    ex("entity->event", "ambulance behind", "bicycle", False),
    ex("entity->event", "pet outside", "pet", True, domain="manipulation"),
]


def test_metrics_by_hand():
    m = metrics([True, True, False, False], [True, False, True, False])
    assert (m.accuracy, m.precision, m.recall, m.f1) == (0.5, 0.5, 0.5, 0.5)
    m = metrics([True, True, False], [True, True, True])
    assert m.precision == pytest.approx(2 / 3) and m.recall == 1.0
    assert m.f1 == pytest.approx(0.8)
    m = metrics([False, False], [False, False])  # nothing to find, nothing claimed
    assert (m.accuracy, m.precision, m.recall) == (1.0, 1.0, 1.0)
    m = metrics([True], [False])
    assert (m.precision, m.recall, m.f1) == (0.0, 0.0, 0.0)


def test_oracle_and_accept_all_judges():
    truth = {(e.source, e.candidate) for e in EXAMPLES if e.label}
    calls = []

    def oracle(kind, source, candidates, *, context=None, domain="driving"):
        calls.append((kind, source, tuple(candidates)))
        return {c for c in candidates if (source, c) in truth}

    rep = evaluate_edges(EXAMPLES, oracle, trials=3)
    assert len(calls) == 9  # 3 calls (one per source, all its candidates at once) x 3 trials
    assert calls[0] == ("event->event", "ego stops", ("jaywalker in front", "ambulance behind",
                                                      "jaywalker in another city",
                                                      "radio plays a song"))
    assert [(g.domain, g.kind) for g in rep.groups] == [
        ("driving", "event->event"), ("driving", "entity->event"), ("manipulation", "entity->event")]
    for g in rep.groups:
        assert (g.accuracy.mean, g.f1.mean, g.f1.std) == (1.0, 1.0, 0.0)

    rep = evaluate_edges(EXAMPLES, lambda k, s, c, **kw: set(c), trials=2)
    ev = rep.groups[0]
    assert (ev.accuracy.mean, ev.precision.mean, ev.recall.mean) == (0.5, 0.5, 1.0)


def test_varying_judge_gives_a_spread_and_failures_are_counted():
    state = {"t": 0}

    def flaky(kind, source, candidates, *, context=None, domain="driving"):
        if source == "pet outside":
            raise LLMError("model answer did not validate")
        state["t"] += 1
        # alternate between accepting the first candidate and accepting all of them
        return set(candidates[:1]) if state["t"] % 2 else set(candidates)

    rep = evaluate_edges(EXAMPLES[:4] + EXAMPLES[6:], flaky, trials=2)
    ev = rep.groups[0]
    assert [t.accuracy for t in ev.trials] == [0.75, 0.5]
    assert ev.accuracy.mean == pytest.approx(0.625) and ev.accuracy.std == pytest.approx(0.125)
    pet = rep.groups[1]
    assert pet.failed_calls == 2 and pet.recall.mean == 0.0


def test_load_file_and_errors(tmp_path):
    f = tmp_path / "edges.jsonl"
    f.write_text("# comment\n" + json.dumps({"kind": "event->event", "source": "a",
                                             "candidate": "b", "label": True, "domain": "driving"}) + "\n\n")
    got = load_edge_examples(f)
    assert got[0].domain == "driving" and got[0].context is None
    f.write_text(json.dumps({"kind": "event->event", "source": "a", "candidate": "b", "label": True}) + "\n")
    with pytest.raises(ConfigError, match="line 1: domain: Field required"):
        load_edge_examples(f)
    f.write_text(json.dumps({"kind": "event->entity", "source": "a", "candidate": "b",
                             "label": True}) + "\n")
    with pytest.raises(ConfigError, match="line 1: kind"):
        load_edge_examples(f)
    f.write_text("# only comments\n")
    with pytest.raises(ConfigError, match="no labeled examples"):
        load_edge_examples(f)
    with pytest.raises(ConfigError):
        load_edge_examples(tmp_path / "missing.jsonl")
    with pytest.raises(ConfigError):
        evaluate_edges(got, lambda *a, **k: set(), trials=0)


def test_bundled_file_covers_domains_and_kinds():
    rows = load_edge_examples(bundled_edge_examples())
    for domain in ("driving", "manipulation"):
        mine = [r for r in rows if r.domain == domain]
        assert len(mine) >= 20
        assert {r.kind for r in mine} == set(KINDS)
        assert any(r.label for r in mine) and any(not r.label for r in mine)
    # candidates are unique within one edge-construction call
    keys = [(r.domain, r.kind, r.source, r.context, r.candidate) for r in rows]
    assert len(keys) == len(set(keys))


def test_entity_candidates_are_database_assets():
    from regen import domains

    for r in load_edge_examples(bundled_edge_examples()):
        if r.kind == "entity->event":
            db = domains.make(r.domain).database()
            assert r.candidate in db.assets, r.candidate


def test_context_chain():
    from regen.evaluation.edges import context_chain

    assert context_chain("stop <- ambulance behind <- ambulance", "ambulance") == [
        "ambulance behind", "stop"]
    assert context_chain("stop <- ambulance behind", "x") == ["ambulance behind", "stop"]
    assert context_chain(None, "x") == []


def test_model_judge_adapts_to_judge_candidates(monkeypatch):
    import regen.expand.construct as expand_edges
    from regen.evaluation.edges import model_judge

    seen = []

    def fake(llm, kind, source, candidates, *, domain="driving", context=None, database=None):
        seen.append((kind, source, list(candidates), domain, context))
        return {candidates[0]}

    monkeypatch.setattr(expand_edges, "judge_candidates", fake)
    judge = model_judge(llm=object())
    assert judge("event->event", "stop", ["a", "b"], domain="driving") == {"a"}
    # a property row goes to the same call shape as expansion: the whole entity at once
    got = judge("property->entity", "ambulance", ["siren: on", "siren: off", "start_location: behind"],
                context="stop <- ambulance behind <- ambulance", domain="driving")
    assert got == {"siren: on"}
    assert seen[0] == ("event->event", "stop", ["a", "b"], "driving", None)
    assert seen[1] == ("property->entity", "ambulance", ["siren: on", "siren: off", "start_location: behind"],
                       "driving", ["ambulance behind", "stop"])


def test_fresh_judge_per_trial():
    made = []

    def factory(t):
        made.append(t)
        return lambda kind, source, candidates, **kw: set(candidates) if t == 0 else set()

    rep = evaluate_edges(EXAMPLES, trials=2, judge_for_trial=factory)
    assert made == [0, 1]
    assert [m.recall for m in rep.groups[0].trials] == [1.0, 0.0]
    with pytest.raises(ConfigError):
        evaluate_edges(EXAMPLES)


def test_judge_candidates_decides_as_expansion_does():
    """One yes/no question per cause candidate, the domain's mechanics rule after it; one
    consistent property choice per entity (no speed for a stationary actor)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "support"))
    from fake_expansion_model import ScriptedModel

    from regen.expand.construct import judge_candidates
    from regen.llm import LLM
    from regen.llm.testing import FunctionProvider

    model = ScriptedModel(causes={}, plausible={"the room is empty": False},
                          choose={"behavior": ["stationary"], "target_speed": ["fast"]})
    llm = LLM(FunctionProvider(model))
    got = judge_candidates(llm, "event->event", "the robot opens the door",
                           ["the pet wants to come in", "the robot is programmed to open doors",
                            "the room is empty"], domain="manipulation")
    assert got == {"the pet wants to come in"}  # the mechanical one is judged yes, then ruled out
    assert model.kinds == ["judge"] * 3
    got = judge_candidates(llm, "property->entity", "bicycle",
                           ["behavior: stationary", "behavior: change_lane", "target_speed: fast"],
                           domain="driving", context=["a cyclist waits at the roadside", "stop"])
    assert "behavior: stationary" in got and not any(g.startswith("target_speed") for g in got)
    assert model.kinds[-1] == "properties" and model.kinds.count("properties") == 1


def test_the_bundled_split_is_fixed_whole_calls_on_one_side_both_halves_per_kind():
    rows = load_edge_examples(bundled_edge_examples())
    assert all(r.split in ("tune", "test") for r in rows)
    side: dict[tuple, str] = {}
    for r in rows:  # one call's candidates are judged together: never split across halves
        assert side.setdefault((r.domain, r.kind, r.source, r.context), r.split) == r.split
    for domain in ("driving", "manipulation"):
        for kind in KINDS:
            halves = {r.split for r in rows if (r.domain, r.kind) == (domain, kind)}
            assert halves == {"tune", "test"}, (domain, kind)


def test_metrics_are_reported_per_split():
    rows = [r.model_copy(update={"split": "tune" if r.source == "ego stops" else "test"}) for r in EXAMPLES]
    rows.append(ex("event->event", "ego slows", "a slow truck ahead", True).model_copy(update={"split": "test"}))
    rep = evaluate_edges(rows, lambda k, s, c, **kw: set(c), trials=1)  # accepts everything
    by = {(g.domain, g.kind, g.split): g for g in rep.groups}
    assert set(by) == {("driving", "event->event", "tune"), ("driving", "event->event", "test"),
                       ("driving", "entity->event", "test"), ("manipulation", "entity->event", "test")}
    assert by[("driving", "event->event", "tune")].accuracy.mean == 0.5  # 2 of 4 are causes
    assert by[("driving", "event->event", "test")].accuracy.mean == 1.0
    assert by[("driving", "event->event", "test")].examples == 1


def test_a_place_the_event_says_is_the_location_whatever_the_model_picks():
    """A free-valued property (a place) is named by the offered value the event says whole."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "support"))
    from fake_expansion_model import ScriptedModel

    from regen.assets.database import database_of
    from regen.expand.construct import judge_candidates
    from regen.expand.properties import named_states
    from regen.llm import LLM
    from regen.llm.testing import FunctionProvider

    model = ScriptedModel(causes={}, choose={"location": ["inside the oven"]})  # the model is wrong
    llm = LLM(FunctionProvider(model))
    event = "the fruit left on the counter is going bad"
    got = judge_candidates(llm, "property->entity", "fruit",
                           ["location: on the counter", "location: inside the oven"],
                           domain="manipulation", context=[event, "the robot opens the fridge"])
    assert got == {"location: on the counter"}
    db = database_of("manipulation")
    options = {"location": ("where", ["on the counter", "near the counter"])}
    assert named_states(db, "fruit", event, options) == {"location": ("on the counter", "on the counter")}
    # a place the words do not say whole, or two places said, name nothing
    assert named_states(db, "fruit", "the fruit is going bad", options) == {}
    both = {"location": ("where", ["on the counter", "counter"])}
    assert named_states(db, "fruit", event, both) == {}


def test_a_place_the_event_names_by_its_words_or_by_going_elsewhere_is_the_start() -> None:
    from regen.assets.database import database_of
    from regen.expand.properties import named_states

    db = database_of("manipulation")
    rack = {"location": ("where", ["on the drying rack", "inside the cabinet"])}
    # the place's own words, not said whole
    assert named_states(db, "dishes", "the clean plates are drying next to the sink", rack) == {
        "location": ("on the drying rack", "drying")}
    assert named_states(db, "dishes", "plates drying in the cabinet", rack) == {}  # both places' words
    # the item has still to go somewhere: the place said after that, or in the object the task
    # acts on, is where it goes; the start is the one other place
    fridge = {"location": ("where", ["on the table", "inside the fridge"])}
    assert named_states(db, "bottle", "the milk has to go back into the fridge", fridge) == {
        "location": ("on the table", "go back")}
    assert named_states(db, "bottle", "the milk bottle must be chilled", fridge, frozenset({"fridge"})) == {
        "location": ("on the table", "be chilled")}
    assert named_states(db, "bottle", "the milk bottle must be chilled", fridge) == {}  # goes where?
    said = {"location": ("where", ["on the table", "in the fridge"])}  # said whole, but as the goal
    assert named_states(db, "bottle", "the milk has to go back in the fridge", said) == {
        "location": ("on the table", "go back")}
    # a device's power in the words of what it does
    assert db.named_state("laptop", "power", "the laptop's battery died") == ("off", "battery died")
    assert db.named_state("tv", "power", "a match is blaring on the tv") == ("on", "blaring")
