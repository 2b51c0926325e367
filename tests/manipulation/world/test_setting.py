"""The typed world settings of a manipulation scenario."""

from __future__ import annotations

import pytest

from regen.core import Scenario
from regen.errors import ConfigError
from regen.manipulation.world.setting import ManipulationWorld


def _scenario(world: dict) -> Scenario:
    from manipulation_chains import door_scenario

    sc = door_scenario({}, [])
    return sc.model_copy(update={"world": world})


def test_grounding_writes_the_world_keys_in_their_order_and_defaults_hold() -> None:
    from manipulation_chains import door_scenario

    sc = door_scenario({}, [], seed=2)
    assert list(sc.world.items()) == [("behavior", "open_door"), ("duration", 12.0), ("seed", 2),
                                      ("simulator", "pybullet")]
    w = ManipulationWorld.of(sc)
    assert (w.behavior, w.duration, w.seed) == ("open_door", 12.0, 2) and w.as_world() == sc.world
    assert ManipulationWorld.of(_scenario({})).duration == 12.0


def test_a_bad_duration_is_refused_naming_the_scenario_and_the_key() -> None:
    sc = _scenario({"behavior": "open_door", "duration": "soon"})
    with pytest.raises(ConfigError, match=rf"scenario '{sc.id}': world\.duration = 'soon' is not valid"):
        ManipulationWorld.of(sc)
