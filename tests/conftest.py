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


@pytest.fixture(scope="session", autouse=True)
def _nothing_written_in_the_checkout():
    # A command under test that falls back to the working directory would litter the checkout
    # (it happened once: a results folder was committed). Fail the run if the top level changes.
    root = Path(__file__).resolve().parents[1]
    before = {p.name for p in root.iterdir()}
    yield
    # hidden entries are tools' caches (.grimp_cache from the import-contract test), ignored by git
    added = sorted({p.name for p in root.iterdir() if not p.name.startswith(".")} - before)
    assert not added, f"tests wrote into the checkout: {added}"


@pytest.fixture
def shared_cache() -> Path:
    """Use the user's real cache dir (model files, maps) instead of a fresh one."""
    from regen.paths import cache_dir

    return cache_dir()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
