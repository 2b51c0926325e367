"""Fixtures of the manipulation policy tests (real PyBullet)."""

from __future__ import annotations

import pytest
from manipulation_chains import door_scenario

pytest.importorskip("pybullet")


@pytest.fixture(scope="session")
def pet_in_reach():
    """Open the door with a pet on the floor right of the robot (within the arm's reach) and
    a book on the table; the scripted controller verifies in it."""
    return door_scenario({"pet1": ("right_of", "robot"), "book1": ("on", "table")}, ["pet", "book"])


@pytest.fixture(scope="session")
def harness():
    from regen.manipulation.testing.harness import ManipulationHarness

    return ManipulationHarness()
