"""The typed world settings of a driving scenario: what grounding writes, what simulation reads,
and a clear error naming the scenario and the key for a bad scenario file."""

from __future__ import annotations

import json

import pytest
from driving_chains import FEASIBLE

from regen.driving.grounding.rules import ground_rule_based, template_of
from regen.driving.world.setting import DrivingWorld
from regen.errors import ConfigError


def _scenario(**world: object):
    sc = ground_rule_based(FEASIBLE["stop_abruptly"][0], seed=3)
    return sc.model_copy(update={"world": {**sc.world, **world}})


def test_grounding_writes_the_world_keys_in_their_order() -> None:
    sc = ground_rule_based(FEASIBLE["stop_abruptly"][0], seed=3)
    assert json.dumps(sc.world) == ('{"map": "straight", "ego_template": "stop_abruptly", "duration": 16.0, '
                                    '"dt": 0.1, "seed": 3, "grounder": "rule-based"}')
    w = DrivingWorld.of(sc)
    assert (w.map, w.ego_template, w.duration, w.dt, w.seed, w.grounder) == (
        "straight", "stop_abruptly", 16.0, 0.1, 3, "rule-based")
    assert w.as_world() == sc.world and list(w.as_world()) == list(sc.world)


def test_defaults_and_keys_of_other_writers_are_kept() -> None:
    w = DrivingWorld.of(_scenario(rule_parts="fsm", note="kept"))
    assert w.model_extra == {"note": "kept"} and w.as_world()["note"] == "kept"
    bare = DrivingWorld.model_validate({"map": "straight"})
    assert (bare.duration, bare.dt, bare.seed, bare.ego_template) == (16.0, 0.1, 0, None)
    assert bare.updated(grounder="model").as_world() == {"map": "straight", "duration": 16.0, "dt": 0.1,
                                                          "seed": 0, "grounder": "model"}


def test_a_bad_seed_is_refused_naming_the_scenario_and_the_key() -> None:
    sc = _scenario(seed="abc")
    with pytest.raises(ConfigError, match=rf"scenario '{sc.id}': world\.seed = 'abc' is not valid"):
        DrivingWorld.of(sc)
    with pytest.raises(ConfigError, match=r"world\.seed = 'abc'"):
        template_of(sc)  # every reader goes through the typed view
    with pytest.raises(ConfigError, match=r"world\.duration = 'long'"):
        DrivingWorld.of(_scenario(duration="long"))


def test_simulation_needs_a_map_and_says_so() -> None:
    from regen.driving.simulation.scenario import map_name, timing

    sc = _scenario()
    assert map_name(sc) == "straight" and timing(sc) == (0.1, 160, 3)
    no_map = sc.model_copy(update={"world": {k: v for k, v in sc.world.items() if k != "map"}})
    with pytest.raises(ConfigError, match=rf"scenario '{sc.id}': world\.map is missing"):
        map_name(no_map)
