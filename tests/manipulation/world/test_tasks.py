"""Task registry: keyword matching, success predicates, rewards."""

from __future__ import annotations

import numpy as np
import pytest

from regen.errors import ConfigError
from regen.manipulation.world.tasks import BEHAVIORS, match_behavior, resolve


@pytest.mark.parametrize("text,expected", [
    ("the robot opens the door", "open_door"), ("Close the window, it's cold", "close_window"),
    ("the robot adjusts the water flow at the faucet", "adjust_faucet"),
    ("turn on the lamp", "turn_on_lamp"), ("the robot pulls the drawer out", "pull_drawer"),
    ("the robot retrieves an item from the fridge", "retrieve_from_fridge"),
    ("the robot carries the bucket", "carry_bucket"), ("tilt the display", "tilt_display"),
])
def test_keyword_matcher(text, expected):
    assert match_behavior(text).id == expected


def test_unknown_text_and_reward_raise_config_errors():
    with pytest.raises(ConfigError, match="no manipulation behavior"):
        match_behavior("the robot juggles")
    with pytest.raises(ConfigError, match="unknown manipulation behavior"):
        resolve("fly", "whatever")
    assert resolve("open_door", "the robot carries the bucket").id == "open_door"


def test_twelve_behaviors_with_success_predicates():
    assert len(BEHAVIORS) >= 12
    assert all(b.success for b in BEHAVIORS.values())


def test_articulation_reward_prefers_progress():
    r = BEHAVIORS["open_door"].reward
    handle = np.array([0.5, 0.2, 0.8])
    far = r({"ee": np.zeros(3), "handle": handle, "fraction": 0.0})
    at = r({"ee": handle, "handle": handle, "fraction": 0.0})
    opened = r({"ee": handle, "handle": handle, "fraction": 0.45})
    assert far < at < opened
