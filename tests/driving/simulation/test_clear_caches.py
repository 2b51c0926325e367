"""The per-step cache clearing of simulated objects (regen.driving.simulation.run._clear_caches):
the same attributes gone as after Scenic's own ``_clearCaches``, and a scenario simulated with
Scenic's clearing records the very trace it records with ours."""

from __future__ import annotations

import pytest
from driving_chains import chain_simulator

from regen.driving.simulation import run as run_module

pytest.importorskip("scenic")

CHAINS = [("stop_abruptly", 0), ("stop_in_intersection", 0), ("change_lane", 0)]


def _cached_names(obj) -> set[str]:
    proxy = object.__getattribute__(obj, "_dynamicProxy")
    return {k for k in object.__getattribute__(proxy, "__dict__") if k.startswith("_cached_")}


def test_it_deletes_what_scenics_clearing_deletes(monkeypatch) -> None:
    """Every simulated object at every step, its cached properties computed first:
    ours and Scenic's leave the same attributes, and the cached values are gone (recomputed)."""
    seen: list[tuple[str, set[str], set[str]]] = []
    original = run_module._clear_caches

    def compare(obj) -> None:
        for name in ("visibleRegion", "occupiedSpace", "boundingBox", "corners", "inradius"):
            try:
                getattr(obj, name)  # computes and caches it
            except Exception:  # noqa: BLE001 (a property this class cannot compute here)
                pass
        assert _cached_names(obj), "no cached property was computed: the comparison proves nothing"
        store = object.__getattribute__(object.__getattribute__(obj, "_dynamicProxy"), "__dict__")
        kept = dict(store)
        obj._clearCaches()
        scenic_left = set(store)
        store.clear()
        store.update(kept)  # as it was, then ours
        original(obj)
        seen.append((type(obj).__name__, scenic_left, set(store)))

    monkeypatch.setattr(run_module, "_clear_caches", compare)
    chain_simulator("stop_in_intersection", 0)()
    assert len(seen) > 100 and len({cls for cls, _, _ in seen}) >= 1
    for cls, theirs, ours in seen:
        assert ours == theirs, (cls, theirs ^ ours)


@pytest.mark.slow
@pytest.mark.parametrize("key,i", CHAINS)
def test_a_scenario_records_the_same_trace_with_scenics_clearing(key, i, monkeypatch) -> None:
    simulate = chain_simulator(key, i)
    ours = simulate()
    with monkeypatch.context() as m:
        m.setattr(run_module, "_clear_caches", lambda obj: obj._clearCaches())
        theirs = simulate()
    for column in ("times", "x", "y", "heading", "speed"):
        assert getattr(ours, column) == getattr(theirs, column), column


def test_a_class_whose_attributes_are_not_on_the_proxy_takes_scenics_clearing() -> None:
    class Plain:
        _cache_clearers: dict = {}

    assert run_module._clearing_plan(Plain) is None
