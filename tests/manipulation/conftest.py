"""Shared by the manipulation tests: LeRobot's own environment (``.venv-lerobot``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture
def lerobot_python() -> Path:
    """The python of LeRobot's environment (REGEN_LEROBOT_VENV, else .venv-lerobot of the
    checkout). Where it is missing the test is skipped, except on CI (CI=true), which installs it
    with setup.sh: there a missing environment fails."""
    from regen.errors import ConfigError
    from regen.manipulation.export.lerobot_check import lerobot_python as find

    try:
        return find()
    except ConfigError as exc:
        if os.environ.get("CI") == "true":
            raise
        pytest.skip(str(exc))
