"""Fixtures of the ``regen falsify`` tests: small run folders built without a model (rule
grounding), one driving (a child runs across the road, and a graph that proposed a second
cause) and one manipulation (open the door for the pet, a desk lamp on)."""

from __future__ import annotations

from pathlib import Path

import pytest
from falsify_runs import CHILD, OTHER_CAUSE, write_run


@pytest.fixture(scope="session")
def _falsify_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("regen-falsify-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(_falsify_cache, monkeypatch):
    """Overrides the root fixture: these tests share one cache per session, so each map is
    generated once, not once per test."""
    monkeypatch.setenv("REGEN_CACHE_DIR", str(_falsify_cache))


@pytest.fixture(scope="session")
def driving_run(tmp_path_factory, _falsify_cache) -> Path:
    """A driving run: one verified scenario (a child runs across the road, caused) and a graph
    whose expansion also proposed a road worker crossing."""
    pytest.importorskip("scenic")
    from driving_chains import FEASIBLE

    from regen.pipeline import run_path
    from regen.runfolder import RunFolder

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(_falsify_cache))
        run = tmp_path_factory.mktemp("drive-run")
        path = FEASIBLE["stop_abruptly"][0]
        out = run_path(path, run / RunFolder.SCENARIOS / CHILD, pictures=False)
        assert out.verdict.feasible and out.verdict.causal.status == "caused", out.verdict.reason
        write_run(run, path, [CHILD], [path.events[0], OTHER_CAUSE])
    return run


def _search(driving_run, tmp_path_factory, cache, policy: str, budget: int):
    from regen.falsify import run_falsify

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(cache))
        out = tmp_path_factory.mktemp("falsify") / policy
        report = run_falsify(driving_run, policy, budget=budget, out=out, pictures=False, param_budget=0)
    return out, report


@pytest.fixture(scope="session")
def searched(driving_run, tmp_path_factory, _falsify_cache):
    """``regen falsify`` of constant-speed over the driving run, budget 3, no pictures: (its
    folder, the Falsification). constant-speed hits the child in the scenario as generated, so
    its baseline is the finding and no edit is searched."""
    return _search(driving_run, tmp_path_factory, _falsify_cache, "constant-speed", 3)


@pytest.fixture(scope="session")
def searched_aeb(driving_run, tmp_path_factory, _falsify_cache):
    """``regen falsify`` of aeb over the driving run, budget 7, no pictures: (its folder, the
    Falsification). aeb stops for the child as generated (its baseline passes), so the edits are
    searched: the baseline, then single edits until a child running fast makes aeb miss the stop
    (the edits that take the child out of the road are invalid: the world no longer calls for a
    stop)."""
    return _search(driving_run, tmp_path_factory, _falsify_cache, "aeb", 7)


@pytest.fixture(scope="session")
def manipulation_run(tmp_path_factory, _falsify_cache) -> Path:
    """A manipulation run: the robot opens the door for the pet, a desk lamp on (verified by the
    scripted controller, rule grounding)."""
    pytest.importorskip("pybullet")
    from regen.core import Behavior, CausePath, PathEntity
    from regen.manipulation.world.tasks import BEHAVIORS
    from regen.pipeline import run_path
    from regen.runfolder import RunFolder

    b = BEHAVIORS["open_door"]
    cause = "the pet wants to go out"
    path = CausePath(behavior=Behavior(text=b.text, domain="manipulation", params={"reward": b.id}),
                     events=[cause, b.text],
                     entities=[PathEntity(asset="pet", event=cause),
                               PathEntity(asset="desk_lamp", event=cause, properties={"power": ["on"]})])
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(_falsify_cache))
        run = tmp_path_factory.mktemp("door-run")
        out = run_path(path, run / RunFolder.SCENARIOS / "01-pet", pictures=False)
        assert out.verdict.feasible, out.verdict.reason
        write_run(run, path, ["01-pet"], [cause])
    return run
