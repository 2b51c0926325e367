"""The bundled fidelity labels: well-formed, fixed split, every behavior covered, every asset
and state one the databases define (or one named as still missing), and the scoring."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from regen.assets.database import database_of
from regen.driving.world.egos import EGO_TEMPLATES
from regen.errors import ConfigError
from regen.evaluation.fidelity import score, table
from regen.evaluation.fidelity_set import load_cases, packaged_sets
from regen.manipulation.world.tasks import BEHAVIORS

# assets and motion primitives the labels name that the databases do not define yet: a case
# that needs one counts as a miss until a database can play it
NOT_YET = {"driving": {"tow_truck", "police_officer", "road_worker", "wrong_way", "wait_at_curb"},
           "manipulation": {"spill", "mop", "ingredients", "visitor"}}


@pytest.mark.parametrize("name", packaged_sets())
def test_bundled_sets_are_complete_and_split_half_and_half(name: str) -> None:
    cases = load_cases(name)
    assert len(cases) >= 60 and {c.domain for c in cases} == {name}
    db = database_of(name)
    for c in cases:
        for e in c.entities:
            assert set(e.any_of) <= set(db.assets) | NOT_YET[name], c.id
            for prop, values in e.states.items():
                assert prop in db.properties, c.id
                known = set(db.properties[prop].states or values)
                assert set(values) <= known | NOT_YET[name], c.id
    behaviors = Counter(c.ego_template or c.reward for c in cases)
    assert set(behaviors) == (set(EGO_TEMPLATES) if name == "driving" else set(BEHAVIORS))
    assert min(behaviors.values()) >= 4
    for b in behaviors:  # the split holds within each behavior, not only overall
        split = Counter(c.split for c in cases if (c.ego_template or c.reward) == b)
        assert abs(split["tune"] - split["test"]) <= 1, b
    terse = [c for c in cases if len(c.cause.split()) <= 4]
    assert len(terse) >= len(cases) // 8  # titles as well as sentences


def test_a_bad_line_is_named_with_its_file_and_line(tmp_path) -> None:
    good = load_cases("driving")[0].model_dump()
    f = tmp_path / "cases.jsonl"
    f.write_text(json.dumps(good) + "\n" + json.dumps({**good, "id": "x", "split": "train"}) + "\n")
    with pytest.raises(ConfigError, match=r"line 2: split"):
        load_cases(f)
    f.write_text(json.dumps(good) + "\n" + json.dumps(good) + "\n")
    with pytest.raises(ConfigError, match="repeats"):
        load_cases(f)


def test_scoring_counts_entities_states_and_verified_but_unfaithful() -> None:
    case = next(c for c in load_cases("driving") if c.cause == "signal changes suddenly")
    light = {"name": "traffic_light1", "asset": "traffic_light", "kind": "object", "behavior": None,
             "properties": {"light_state": "turns_red"}}
    cone = {"name": "traffic_cone1", "asset": "traffic_cone", "kind": "object", "behavior": "stationary",
            "properties": {}}
    ego = {"name": "ego", "asset": "ego", "kind": "robot", "behavior": "stop_abruptly", "properties": {}}
    right = score(case, {"entities": [ego, light]}, "verified")
    wrong = score(case, {"entities": [ego, cone]}, "verified")
    assert (right.entities_ok, right.states_ok, right.states_total) == (True, 1, 1)
    assert (wrong.entities_ok, wrong.states_ok, wrong.label_unfaithful) == (False, 0, True)
    rows = {(r["domain"], r["split"]): r for r in table([right, wrong])}
    row = rows[("driving", "all")]
    assert row["entity_accuracy"] == 0.5 and row["verified_and_unfaithful"] == 1


def test_a_motions_speed_is_read_where_the_scenario_keeps_it() -> None:
    """scenario.json keeps a moving actor's speed class in ``behavior_params``; a label asking
    for target_speed = slow is met by it, and not by a fast one."""
    case = next(c for c in load_cases("driving") if c.cause == "a motorcycle rides slowly in the lane ahead")
    def moto(speed: str) -> dict:
        return {"name": "motorcycle1", "asset": "motorcycle", "kind": "agent", "behavior": "drive_forward",
                "properties": {}, "behavior_params": {"location": "ahead_same_lane", "speed_class": speed}}
    slow, fast = (score(case, {"entities": [moto(s)]}, "verified") for s in ("slow", "fast"))
    assert (slow.states_ok, slow.states_total, slow.label_unfaithful) == (1, 1, False)
    assert (fast.states_ok, fast.label_unfaithful) == (0, True)
