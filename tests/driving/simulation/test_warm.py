"""A driving worker warmed ahead of its first scenario (regen.driving.simulation.warm): the world
model's modules are translated then, so the first scenario translates only its own program."""

from __future__ import annotations

import pytest
from driving_chains import FEASIBLE

from regen.driving.grounding.rules import ground_rule_based
from regen.driving.simulation import compile_cache
from regen.driving.simulation.run import compile_program
from regen.driving.simulation.scenario import scenic_program
from regen.pipeline.stages import warm_stage

pytest.importorskip("scenic")


@pytest.fixture(autouse=True)
def _empty_cache():
    compile_cache.clear()
    yield
    compile_cache.clear()


def test_after_warming_a_scenario_translates_only_its_own_program() -> None:
    seconds = warm_stage(("driving",))
    assert set(seconds) == {"driving"} and seconds["driving"] > 0
    warmed, disk = compile_cache.stats["misses"], compile_cache.stats["disk"]
    assert warmed >= 1 and warmed + disk >= 3  # the ego-only program and the world model's modules
    compile_program(scenic_program(ground_rule_based(FEASIBLE["stop_abruptly"][0], seed=0)))
    assert compile_cache.stats["misses"] == warmed + 1  # the scenario's own program, nothing else
    assert compile_cache.stats["disk"] == disk
    assert compile_cache.stats["hits"] >= warmed + disk - 1
