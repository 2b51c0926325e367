"""Shared fixtures. Every test gets its own cache dir, so nothing leaks into ~/.cache."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch,
                    request: pytest.FixtureRequest) -> None:
    # Tests that need the real shared caches (the joined offline model, generated maps) opt out
    # with @pytest.mark.usefixtures("shared_cache").
    if "shared_cache" in request.fixturenames:
        return
    monkeypatch.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("regen-cache")))


@pytest.fixture
def shared_cache() -> Path:
    """Use the user's real cache dir (model files, maps) instead of a fresh one."""
    from regen.paths import cache_dir

    return cache_dir()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
