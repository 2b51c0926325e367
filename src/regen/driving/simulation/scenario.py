"""A grounded scenario as a Scenic program, run and recorded into a trace."""

from __future__ import annotations

import time

from regen.contract import SimulationOutput
from regen.core.scenario import Scenario
from regen.driving.grounding.rules import plans_for
from regen.driving.simulation.program import write_program
from regen.driving.world.maps import ensure_map, geometry
from regen.driving.world.setting import DrivingWorld


def timing(scenario: Scenario) -> tuple[float, int, int]:
    """Step [s], step count and seed of a scenario's world."""
    w = DrivingWorld.of(scenario)
    return w.dt, int(round(w.duration / w.dt)), w.seed


def map_name(scenario: Scenario) -> str:
    """The scenario's map; ConfigError when its world names none."""
    return str(DrivingWorld.of(scenario, required=("map",)).map)


def scenic_program(scenario: Scenario) -> str:
    """The Scenic program of a grounded scenario (the map is generated if needed)."""
    _, plans = plans_for(scenario)
    dt, steps, seed = timing(scenario)
    return write_program(plans, map_path=str(ensure_map(map_name(scenario))), dt=dt,
                         max_steps=steps, narrative=scenario.narrative, seed=seed,
                         title=scenario.behavior.text)


def simulate_scenario(scenario: Scenario) -> SimulationOutput:
    """Write, compile and run the scenario; SimulationError on any simulator failure."""
    from regen.driving.simulation.record import build_trace
    from regen.driving.simulation.run import run_program

    _, plans = plans_for(scenario)
    name = map_name(scenario)
    dt, steps, seed = timing(scenario)
    run = run_program(scenic_program(scenario), steps=steps, dt=dt, seed=seed)
    t0 = time.perf_counter()
    trace = build_trace(run, plans, geometry(name), map_path=str(ensure_map(name)), seed=seed,
                        meta={"scenario": scenario.id})
    timings = dict(run.timings)
    timings["record"] = time.perf_counter() - t0
    return SimulationOutput(trace=trace, timings=timings)


__all__ = ["scenic_program", "simulate_scenario", "timing"]
