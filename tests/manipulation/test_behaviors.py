"""Behavior registry: keyword matching, rewards, URDF generation."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from regen.errors import ConfigError
from regen.manipulation.behaviors import BEHAVIORS, match_behavior, resolve
from regen.manipulation.urdf import FURNITURE, furniture


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


@pytest.mark.parametrize("kind", sorted(FURNITURE))
def test_urdf_is_well_formed_and_names_its_joint(kind):
    spec = furniture(kind)
    root = ET.fromstring(spec.urdf)
    joints = {j.get("name"): j for j in root.iter("joint")}
    links = {link.get("name") for link in root.iter("link")}
    if spec.joint:
        assert spec.joint in joints and joints[spec.joint].get("type") in ("revolute", "prismatic")
    if spec.handle_link:
        assert spec.handle_link in links
    # materials are unique per visual (PyBullet shares colours between equal names)
    names = [m.get("name") for m in root.iter("material")]
    assert len(names) == len(set(names))
