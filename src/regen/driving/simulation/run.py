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
import numbers
import random
import threading
import time
from collections import OrderedDict
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


def object_properties(sim, obj, properties) -> dict:
    """What Scenic's Newtonian simulation reports of ``obj`` after a step (its
    ``getProperties``, value for value), with the one costly part memoized per simulation.

    Scenic turns the object's heading into a yaw in its parent's frame through two scipy
    rotations and its random-value checks at every step, for every object: 0.3 ms each, the
    largest part of a simulated step (profiled, issue 39). That yaw is a pure function of the
    parent orientation's quaternion and the heading, and most objects keep their heading from
    one step to the next (parked, walking straight, driving a straight lane), so it is computed
    once per (quaternion, heading), keyed on the heading's exact bits (0.0 and -0.0 apart)."""
    memo = sim.__dict__.setdefault("_regen_yaw", {})
    parent, heading = obj.parentOrientation, obj.heading
    key = (parent.q.tobytes(), heading, math.copysign(1.0, heading))
    yaw = memo.get(key)
    if yaw is None:
        yaw, _, _ = parent.globalToLocalAngles(heading, 0, 0)
        memo[key] = yaw
    values = dict(position=obj.position, yaw=yaw, pitch=0, roll=0, velocity=obj.velocity,
                  speed=obj.speed, angularSpeed=obj.angularSpeed, angularVelocity=obj.angularVelocity)
    if "elevation" in properties:
        values["elevation"] = obj.elevation
    return values


def _bits(v: float) -> tuple[float, float]:
    """A float as a memo key: its value and sign (0.0 and -0.0 apart)."""
    return v, math.copysign(1.0, v)


@functools.cache
def _oriented_recomputers() -> dict:
    """Scenic's recomputers of an oriented object's dynamic final properties (its orientation
    from parent orientation, yaw, pitch and roll; its heading from those), by property."""
    from scenic.core.object_types import OrientedPoint

    return dict(OrientedPoint._dynamicFinalProperties)


def _recompute_finals(memo: dict, obj) -> None:
    """``obj._recomputeDynamicFinals()``, the values memoized per simulation: for an object whose
    dynamic finals are Scenic's orientation and heading (all of the driving model's), they are a
    pure function of its class, parent orientation, yaw, pitch and roll (two scipy rotations at
    every step otherwise); the same values are specified in the same order."""
    from scenic.core.lazy_eval import valueInContext

    finals = obj._dynamicFinalProperties
    if finals != _oriented_recomputers():
        obj._recomputeDynamicFinals()
        return
    # while it is simulated, an object's properties live on its dynamic proxy (Scenic's own
    # method runs bound to it): read and specify them there
    proxy = object.__getattribute__(obj, "_dynamicProxy")
    parent = proxy.parentOrientation
    key = (type(proxy), id(parent), *_bits(proxy.yaw), *_bits(proxy.pitch), *_bits(proxy.roll))
    values = memo.get(key)
    if values is None:
        values = []
        for prop, recomputer in finals.items():  # as Scenic does it, the values kept
            value = valueInContext(recomputer(proxy), proxy)
            proxy._specify(proxy, prop, value)
            values.append((prop, value))
        memo[key] = (parent, values)  # the parent kept alive: its id stays its own
        return
    for prop, value in values[1]:
        proxy._specify(proxy, prop, value)


def update_objects(sim) -> None:
    """Scenic's ``Simulation.updateObjects`` (every simulator-provided property read, checked
    and assigned, dynamic finals recomputed, caches cleared), with the dynamic finals memoized
    (:func:`_recompute_finals`). A simulation that writes or checks a replay's divergence data
    takes Scenic's own (regen's do neither)."""
    if (sim._replayOut and sim._writeDivergenceData) or sim.replayCanContinue():
        from scenic.core.simulators import Simulation

        Simulation.updateObjects(sim)
        return
    memo = sim.__dict__.setdefault("_regen_finals", {})
    for obj in sim.objects:
        dyn_types = obj._simulatorProvidedProperties
        properties = set(dyn_types)
        values = sim.getProperties(obj, properties)
        assert properties == set(values), properties ^ set(values)
        for prop, value in values.items():
            ty = dyn_types[prop]
            if ty is float and isinstance(value, numbers.Real):
                value = float(value)
            elif ty is type(None):
                ty = type(value)
                dyn_types[prop] = ty
            if not isinstance(value, ty):
                raise RuntimeError(f'simulator provided value for property "{prop}" with type '
                                   f"{type(value).__name__} instead of expected {ty.__name__}")
            setattr(obj, prop, value)
        _recompute_finals(memo, obj)
        _clear_caches(obj)


@functools.cache
def _cached_clearer_code():
    """The code of the clearer Scenic's ``@cached`` gives a method (``delattr`` of the value it
    stored as ``_cached_<name>``, an AttributeError passed)."""
    from scenic.core.utils import cached

    return cached(lambda self: None)._scenic_cache_clearer.__code__


@functools.cache
def _clearing_plan(cls: type) -> tuple[tuple[str, ...], tuple] | None:
    """How to clear the per-step caches of a ``cls`` object: the attribute names Scenic's
    ``@cached`` clearers delete, and the other clearers (called as they are); None where the
    names cannot be popped from the dynamic proxy's ``__dict__`` directly (then Scenic's own
    ``_clearCaches`` runs)."""
    from scenic.core.object_types import Object

    if cls.__delattr__ is not Object.__delattr__:
        return None
    names, others = [], []
    for clearer in cls._cache_clearers.values():
        if clearer.__code__ is _cached_clearer_code():
            name = dict(zip(clearer.__code__.co_freevars, clearer.__closure__, strict=True))["storageName"].cell_contents
            if hasattr(getattr(cls, name, None), "__delete__"):  # a descriptor would take the delete
                return None
            names.append(name)
        else:
            others.append(clearer)
    return tuple(names), tuple(others)


def _clear_caches(obj) -> None:
    """``obj._clearCaches()``, the same attributes deleted: Scenic tries ``delattr`` for each of
    about 36 cached properties of every object at every step, most of them not computed since the
    last step, and pays an AttributeError each time (12 % of a replayed scenario, profiled, issue
    39); here the computed ones are popped from the dynamic proxy's ``__dict__``, where Scenic's
    ``Object.__delattr__`` deletes them."""
    plan = _clearing_plan(type(obj))
    if plan is None:
        obj._clearCaches()
        return
    names, others = plan
    store = object.__getattribute__(object.__getattribute__(obj, "_dynamicProxy"), "__dict__")
    for name in names:
        store.pop(name, None)
    for clearer in others:
        clearer(obj)


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

        def getProperties(self, obj, properties):
            return object_properties(self, obj, properties)

        def updateObjects(self):
            update_objects(self)

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


@contextlib.contextmanager
def quiet_behaviors():
    """Scenic's stuck-behavior warning off for the block (restored as it was after it).

    Scenic arms an alarm around every step of every behavior (``StuckBehaviorWarning`` after
    ``scenic.core.dynamics.stuckBehaviorWarningTimeout`` [s]): four signal calls a step, which
    measured 5% of a driving scenario's simulation and causal check. The alarm only warns, for a
    hand-written behavior with a loop that never takes an action; the programs run here are
    made from templates, and it stops nothing."""
    from scenic.core import dynamics

    was = dynamics.stuckBehaviorWarningTimeout
    dynamics.stuckBehaviorWarningTimeout = 0
    try:
        yield
    finally:
        dynamics.stuckBehaviorWarningTimeout = was


def compile_program(text: str, *, filename: str = "<regen>"):
    """Compile Scenic source into a scenario; Scenic errors become :class:`SimulationError`.

    Scenic's parsing, 95% of an uncached compilation, goes through the process's statement cache
    (:mod:`regen.driving.simulation.parse_cache`): the world model and the program's helpers are
    parsed once, an actor that differs only in its numbers reuses its parse. The world model's
    modules are translated to bytecode once per process
    (:mod:`regen.driving.simulation.compile_cache`). The cyclic garbage collector waits while
    Scenic compiles (:func:`_collector_paused`). Together: 0.06-0.1 s instead of 1.0-2.0 s per
    compilation, the same compiled scenario. One compilation at a time per process (Scenic's
    compiler state is global): threads wait for each other here."""
    from regen.driving.simulation.compile_cache import cached_compilation

    scenic, _ = scenic_modules()
    try:
        with cached_compilation(), _collector_paused():
            return scenic.scenarioFromString(text, filename=filename, mode2D=True)
    except Exception as exc:  # Scenic raises many error types; all mean "this program is bad"
        raise SimulationError(f"Scenic could not compile the program: {type(exc).__name__}: {exc}") from exc


_RECENT: OrderedDict[str, object] = OrderedDict()  # program text -> its compiled scenario, the last few run
KEEP_RECENT = 4  # compiled programs kept (each holds its own copy of the road network)


def recently_compiled(text: str):
    """The compiled scenario of a program :func:`run_program` ran lately, or None. Scenic makes
    a fresh scene (fresh objects and behaviors) at every ``generate``, so it serves again."""
    with _RECENT_LOCK:
        return _RECENT.get(text)


_RECENT_LOCK = threading.Lock()


def _compiled(text: str):
    """``compile_program(text)``, or the compiled scenario of the same text run lately."""
    scenario = recently_compiled(text)
    if scenario is None:
        scenario = compile_program(text)
        with _RECENT_LOCK:
            _RECENT[text] = scenario
            while len(_RECENT) > KEEP_RECENT:
                _RECENT.popitem(last=False)
    return scenario


def run_program(text: str, *, steps: int, dt: float, seed: int = 0) -> RawRun:
    """Compile and simulate ``steps`` steps of ``dt`` seconds; return what was recorded. The
    compiled program is kept a while (:func:`recently_compiled`): the causal check's reference
    runs of the same scenario start from it."""
    t0 = time.perf_counter()
    scenario = _compiled(text)
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
        with quiet_behaviors():
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
