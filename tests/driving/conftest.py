import pytest


@pytest.fixture(scope="session")
def _driving_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("regen-driving-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(_driving_cache, monkeypatch):
    """Overrides the root fixture: driving tests share one cache per session, so each map is
    generated (and parsed by Scenic into its .snet) once, not once per test."""
    monkeypatch.setenv("REGEN_CACHE_DIR", str(_driving_cache))


@pytest.fixture(scope="module")
def straight_map(tmp_path_factory):
    """The generated straight-road map in a cache of its own (module scope: drawn tests share it)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        from regen.driving.world.maps import ensure_map

        yield ensure_map("straight")


@pytest.fixture(scope="session")
def chain_result(tmp_path_factory):
    """``chain_result(key, i)``: the hand-written feasible chain ``FEASIBLE[key][i]`` through the
    main job's stages (rule-based grounding), run once per session (several modules check it)."""
    pytest.importorskip("scenic")
    from driving_chains import FEASIBLE

    from regen.pipeline import run_path

    root = tmp_path_factory.mktemp("chains")
    done: dict = {}

    def get(key: str, i: int):
        if (key, i) not in done:
            done[(key, i)] = run_path(FEASIBLE[key][i], root / f"{key}-{i}", pictures=False)
        return done[(key, i)]

    return get
