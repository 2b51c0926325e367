"""A behavior's parameters belong to its domain: ``Behavior.params``, checked by the domain's
params model; files of the old layout (top-level ego_template / route / reward) still load, and
the hashes made from a behavior stay what they were."""

from __future__ import annotations

import json

import pytest

from regen.core import Behavior, CausePath, PathEntity, Scenario
from regen.core.behavior import make_behavior
from regen.errors import ConfigError

STOP = "the ego-vehicle stops abruptly while driving forward"
DOOR = "the robot opens the door"


def _old(**params: object) -> dict:
    return {"text": STOP, "domain": "driving", "ego_template": None, "route": None, "reward": None, **params}


def test_an_old_layout_behavior_loads_into_params_and_equals_a_new_one() -> None:
    old = Behavior.model_validate(_old(ego_template="stop_abruptly"))
    assert old.params == {"ego_template": "stop_abruptly"}  # the nulls are dropped
    assert old == make_behavior(STOP, "driving", ego_template="stop_abruptly")
    assert json.loads(old.model_dump_json()) == {"text": STOP, "domain": "driving",
                                                 "params": {"ego_template": "stop_abruptly"}}
    assert Behavior.model_validate(_old()).params == {}
    door = Behavior.model_validate({"text": DOOR, "domain": "manipulation", "ego_template": None,
                                    "route": None, "reward": "open_door"})
    assert door == make_behavior(DOOR, "manipulation", reward="open_door")


def test_an_old_scenario_and_path_load_with_their_behavior_in_params() -> None:
    path = CausePath.model_validate({"behavior": _old(ego_template="slow_down"), "events": ["a", STOP]})
    assert path.behavior.params == {"ego_template": "slow_down"}
    data = {"id": "s", "domain": "driving", "behavior": _old(ego_template="slow_down"), "causal_graph": [STOP],
            "narrative": "n", "entities": [{"name": "ego", "asset": "ego", "kind": "ego"}], "fsm": {}}
    assert Scenario.model_validate(data).behavior == path.behavior


def test_a_paths_key_hashes_the_behavior_as_the_old_layout_did() -> None:
    """Scenario ids, folder names and test seeds are made from the key: it is the key of before."""
    import hashlib

    path = CausePath(behavior=Behavior(text=STOP, domain="driving", params={"ego_template": "stop_abruptly"}),
                     events=["a child runs across the road", STOP],
                     entities=[PathEntity(asset="child", event="a child runs across the road",
                                          properties={"behavior": ["cross_the_road"]})])
    old = json.dumps({"behavior": _old(ego_template="stop_abruptly"), "events": path.events,
                      "entities": [e.model_dump() for e in path.entities]}, separators=(",", ":"))
    assert path.key == hashlib.sha256(old.encode()).hexdigest()[:10]
    # the first hand-written chain, as recorded before the behavior had params
    from driving_chains import FEASIBLE

    assert FEASIBLE["stop_abruptly"][0].key == "96e9bad7a7"


def test_a_parameter_of_the_other_domain_is_refused_with_what_to_give() -> None:
    with pytest.raises(ConfigError, match=r"--reward is for manipulation behaviors; driving behaviors "
                                          r"take --ego \(one of: stop_abruptly, "):
        make_behavior(STOP, "driving", reward="open_door")
    with pytest.raises(ConfigError, match=r"--ego is for driving behaviors; manipulation behaviors "
                                          r"take --reward \(one of: adjust_faucet, "):
        make_behavior(DOOR, "manipulation", ego_template="stop_abruptly")


def test_unknown_or_bad_parameters_are_refused_naming_the_key() -> None:
    with pytest.raises(ConfigError, match=r"driving behaviors take no 'speed' \(they take: ego_template, route, recorded, imported\)"):
        make_behavior(STOP, "driving", speed=3)
    with pytest.raises(ConfigError, match=r"manipulation behaviors take no 'route' \(they take: reward\)"):
        make_behavior(DOOR, "manipulation", route=[{"x": 0, "y": 0}])
    with pytest.raises(ConfigError, match=r"route\.0\.x = 'far'"):
        make_behavior(STOP, "driving", route=[{"x": "far", "y": 0}])
    with pytest.raises(ConfigError, match="unknown ego template 'fly'"):
        make_behavior(STOP, "driving", ego_template="fly")
    # the pipeline checks a behavior made without make_behavior the same way
    from regen import domains

    with pytest.raises(ConfigError, match="driving behaviors take no 'speed'"):
        domains.make("driving").check_behavior(Behavior(text=STOP, domain="driving", params={"speed": 3}))


def test_parameters_are_stored_as_checked_json_and_read_typed() -> None:
    from regen import domains
    from regen.driving.world.setting import DrivingParams, Waypoint

    b = make_behavior(STOP, "driving", route=[{"x": 1, "y": 2}], reward=None)
    assert b.params == {"route": [{"x": 1.0, "y": 2.0, "speed": None}]}  # None: not given
    typed = domains.make("driving").params(b)
    assert isinstance(typed, DrivingParams) and typed.route == [Waypoint(x=1.0, y=2.0)]
    assert typed.ego_template is None and DrivingParams.of(b) == typed
    # what run.json records and a resume compares is as before
    assert domains.make("driving").settings_key(b) == {"ego_template": "stop_abruptly"}
    assert domains.make("manipulation").settings_key(make_behavior(DOOR, "manipulation")) == {"reward": "open_door"}


def test_a_domain_without_a_params_model_takes_no_parameters() -> None:
    from regen import domains

    domains.register("aisle", "toydomain:AisleBackend")
    try:
        assert make_behavior("the robot stops in the aisle", "aisle").params == {}
        with pytest.raises(ConfigError, match=r"aisle behaviors take no 'reward' \(they take: no parameters\)"):
            make_behavior("the robot stops in the aisle", "aisle", reward="open_door")
    finally:
        domains.unregister("aisle")
