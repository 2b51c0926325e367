"""Compile a Scenic program, run it on Scenic's Newtonian simulator and record a Trace.

Recording happens inside the simulation (a thin subclass of the Newtonian simulation that keeps
position, heading and speed of every object after each step), so no ``record`` statements are
needed and the exported program stays plain Scenic.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import logging
import math
import random
import time
from dataclasses import dataclass, field

import numpy as np

from regen.errors import DependencyNotInstalled, SimulationError

log = logging.getLogger(__name__)


@dataclass
class RawRun:
    """What one simulation recorded, per Scenic object name, per step."""

    dt: float
    times: list[float]
    x: dict[str, list[float]] = field(default_factory=dict)  # [m]
    y: dict[str, list[float]] = field(default_factory=dict)  # [m]
    heading: dict[str, list[float]] = field(default_factory=dict)  # [rad], from +x
    speed: dict[str, list[float]] = field(default_factory=dict)  # [m/s]
    timings: dict[str, float] = field(default_factory=dict)  # 'compile', 'simulate' [s]


def scenic_modules():
    try:
        import scenic
        from scenic.simulators.newtonian import simulator as newtonian
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled("scenic", "driving", "simulating driving scenarios") from exc
    return scenic, newtonian


Snapshot = list[tuple[float, float, float, float]]  # per object: x [m], y [m], Scenic heading [rad], speed [m/s]


def snapshot(objects) -> Snapshot:
    """The pose and speed of every simulated object at this step."""
    return [(o.position.x, o.position.y, o.heading, math.hypot(o.velocity.x, o.velocity.y))
            for o in objects]


def raw_run(log: list[Snapshot], names: list[str], dt: float, timings: dict[str, float]) -> RawRun:
    """The per-actor columns of a recorded log (headings turned from Scenic's +y to the trace's +x)."""
    run = RawRun(dt=dt, times=[round(k * dt, 6) for k in range(len(log))], timings=timings)
    for i, name in enumerate(names):
        run.x[name] = [float(r[i][0]) for r in log]
        run.y[name] = [float(r[i][1]) for r in log]
        run.heading[name] = [float(r[i][2]) + math.pi / 2 for r in log]
        run.speed[name] = [float(r[i][3]) for r in log]
    return run


@functools.cache
def _recording_simulator_class():
    """A NewtonianSimulator whose simulations record every object after every step."""
    _, newtonian = scenic_modules()

    class RecordingSimulation(newtonian.NewtonianSimulation):
        def setup(self):
            self.regen_log = []
            super().setup()
            self._regen_record()

        def _regen_record(self):
            self.regen_log.append(snapshot(self.objects))

        def step(self):
            super().step()
            self._regen_record()

    class RecordingSimulator(newtonian.NewtonianSimulator):
        def createSimulation(self, scene, **kwargs):
            return RecordingSimulation(scene, self.network, False, False, False, **kwargs)

    return RecordingSimulator


@contextlib.contextmanager
def _collector_paused():
    """Python's cyclic garbage collector off for the block (restored as it was after it).

    A compilation builds tens of thousands of syntax-tree nodes that live until it ends: the
    collector promotes them to its oldest generation and then scans the whole heap (200,000+
    objects once Scenic is loaded) about once per compilation, 0.1 s each (measured: 40% of a
    warm compilation). The trees hold no cycles, so they are freed as the block ends anyway;
    what the compilation keeps is examined once, by the next young collection."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            gc.enable()


def compile_program(text: str, *, filename: str = "<regen>"):
    """Compile Scenic source into a scenario; Scenic errors become :class:`SimulationError`.

    Scenic's parsing, 95% of a compilation, goes through the process's statement cache
    (:mod:`regen.driving.simulation.parse_cache`): the world model and the program's helpers are
    parsed once, an actor that differs only in its numbers reuses its parse. The cyclic garbage
    collector waits while Scenic compiles (:func:`_collector_paused`). Together: 0.14 s instead
    of 1.0-2.0 s per compilation, the same compiled scenario."""
    from regen.driving.simulation.parse_cache import cached_parsing

    scenic, _ = scenic_modules()
    try:
        with cached_parsing(), _collector_paused():
            return scenic.scenarioFromString(text, filename=filename, mode2D=True)
    except Exception as exc:  # Scenic raises many error types; all mean "this program is bad"
        raise SimulationError(f"Scenic could not compile the program: {type(exc).__name__}: {exc}") from exc


def run_program(text: str, *, steps: int, dt: float, seed: int = 0) -> RawRun:
    """Compile and simulate ``steps`` steps of ``dt`` seconds; return what was recorded."""
    t0 = time.perf_counter()
    scenario = compile_program(text)
    t1 = time.perf_counter()
    random.seed(seed)
    np.random.seed(seed)
    try:
        scene, _ = scenario.generate(maxIterations=1, verbosity=0)
    except Exception as exc:
        raise SimulationError(f"Scenic could not place the actors as given: {type(exc).__name__}: "
                              f"{exc}") from exc
    t2 = time.perf_counter()
    simulator = _recording_simulator_class()()
    try:
        sim = simulator.simulate(scene, maxSteps=steps, timestep=dt, verbosity=0,
                                 raiseGuardViolations=False)
    except Exception as exc:
        raise SimulationError(f"the Newtonian simulation failed: {type(exc).__name__}: {exc}") from exc
    t3 = time.perf_counter()
    if sim is None:
        raise SimulationError("the Newtonian simulation was rejected (a requirement failed)")
    names = [getattr(o, "name", f"obj{i}") for i, o in enumerate(scene.objects)]
    return raw_run(sim.regen_log, names, dt,
                   {"compile": t1 - t0, "generate": t2 - t1, "simulate": t3 - t2})
