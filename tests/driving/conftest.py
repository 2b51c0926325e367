import pytest


@pytest.fixture(scope="session")
def _driving_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("regen-driving-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(_driving_cache, monkeypatch):
    """Overrides the root fixture: driving tests share one cache per session, so each map is
    generated (and parsed by Scenic into its .snet) once, not once per test."""
    monkeypatch.setenv("REGEN_CACHE_DIR", str(_driving_cache))
