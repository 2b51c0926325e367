"""A driving policy in the loop: the ego of a grounded scenario driven by a policy, not its template.

The scenario's Scenic program is written as usual except that the ego has no Scenic behavior;
a subclass of Scenic's Newtonian simulation asks the policy for an action before every physics
step and turns it into the ego's throttle, brake and steering (see
:mod:`regen.driving.testing.policies` for the action's meaning), then records every object as
:mod:`regen.driving.simulation.run` does. Every other actor runs its scripted Scenic behavior, its
cause action set off by what this ego does (:mod:`regen.driving.world.triggers`); the property states
the policy observes run on the same warped clocks, from the ego at the same step.

A policy that raises, returns something that is not a finite action, or takes longer than the
per-step timeout ends the episode there: the result carries the reason and the trace up to that
step, never an exception.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import random
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from regen.core.scenario import Scenario
from regen.driving.simulation.record import BRAKE_LIGHT_DECEL
from regen.driving.simulation.run import object_properties, snapshot, update_objects
from regen.driving.testing.policies import (
    MAX_ACCEL,
    MAX_BRAKE,
    ROUTE_AHEAD,
    ActorState,
    EgoState,
    Observation,
    as_action,
)
from regen.driving.world.actors import actor_category
from regen.driving.world.plan import ActorPlan
from regen.driving.world.sensing import LIMITS, effect_of, perceived_error
from regen.driving.world.triggers import warped_time
from regen.errors import SimulationError
from regen.harness.contract import Episode
from regen.harness.timeout import PolicyFailure, reset_policy
from regen.harness.timeout import call_with_timeout as _call_with_timeout

STEP_TIMEOUT = 1.0  # default wall time a policy may take per step [s]
VISIBLE = ("light_state", "siren", "brake_lights", "hazard_lights", "door")


@dataclass
class Prepared:
    """What every episode of one scenario shares: plans, the compiled program, the map."""

    scenario: Scenario
    plans: list[ActorPlan]
    template: object  # regen.driving.world.egos.EgoTemplate
    compiled: object  # scenic Scenario
    dt: float  # [s]
    steps: int
    seed: int
    map_name: str
    map_path: str
    compile_time: float  # [s]
    #: names of objects of ``compiled`` that this world leaves out of every scene it generates
    #: (``compiled`` is the program of a world with more actors: :func:`prepare`'s ``within``)
    leave_out: frozenset[str] = frozenset()
    #: ``compiled`` is the scenario's own program, its ego scripted: each scene drops the ego's
    #: behavior (:func:`prepare`)
    scripted_ego: bool = False


_COMPILED: dict[str, object] = {}  # program text -> compiled Scenic scenario (compiling takes ~1-2 s)


def _program(scenario: Scenario, plans: list[ActorPlan]) -> str:
    """The Scenic program of ``scenario``'s world with these plans (as the simulate stage writes it)."""
    from regen.driving.simulation.program import write_program
    from regen.driving.simulation.scenario import map_name, timing
    from regen.driving.world.maps import ensure_map

    dt, steps, seed = timing(scenario)
    return write_program(plans, map_path=str(ensure_map(map_name(scenario))), dt=dt, max_steps=steps,
                         narrative=scenario.narrative, seed=seed, title=scenario.behavior.text)


def _shared(within: Prepared, plans: list[ActorPlan], text: str) -> frozenset[str] | None:
    """The actors to leave out of ``within``'s program so that it is the program ``text`` of
    ``plans``: None unless ``text`` is exactly ``within``'s program written without them.

    The program writes each actor as its own statement that names no other actor but the ego
    (program.scenic.j2), so a program without some actors compiles to the same objects, the same
    behaviors, minus theirs; generating a scene and leaving their objects out of it simulates
    what compiling the smaller program does, without compiling it (the but-for check's runs,
    :mod:`regen.driving.testing.causal`)."""
    if within.leave_out:
        return None
    names = {p.name for p in plans}
    kept = [p for p in within.plans if p.name in names]
    if len(kept) != len(plans) or _program(within.scenario, kept) != text:
        return None
    return frozenset(p.name for p in within.plans if p.name not in names and p.cls)


def _without_ego_behavior(text: str) -> str | None:
    """A program with its ego's ``with behavior ...`` clause taken out (the clause's line, and
    the comma before it), as the program writes it (program.scenic.j2); None where it has none."""
    lines = text.split("\n")
    start = next((i for i, line in enumerate(lines) if line.startswith("ego = new ")), None)
    if start is None:
        return None
    end = start + 1
    while end < len(lines) and lines[end].startswith("    "):
        end += 1
    last = end - 1  # the statement's last line
    if last == start or not lines[last].startswith("    with behavior ") or not lines[last - 1].endswith(","):
        return None
    return "\n".join(lines[:last - 1] + [lines[last - 1][:-1]] + lines[end:])


def _scripted(scenario: Scenario, scripted_plans: list[ActorPlan], text: str):
    """The compiled program of the scenario with its scripted ego, where the simulate stage has
    just run it (:func:`regen.driving.simulation.run.recently_compiled`) and ``text`` is that
    program without the ego's behavior clause: with the ego's behavior dropped from each scene,
    it is the program ``text`` compiles to (the ego's behavior is its own statement's last
    clause; nothing else reads it). Else None."""
    from regen.driving.simulation.run import recently_compiled

    scripted = _program(scenario, scripted_plans)
    compiled = recently_compiled(scripted)
    if compiled is None or _without_ego_behavior(scripted) != text:
        return None
    return compiled


def prepare(scenario: Scenario, *, within: Prepared | None = None) -> Prepared:
    """Plans and the compiled Scenic program with a behavior-less ego (cached per program).

    Compiling is skipped where a program already compiled serves: the scenario's own program,
    its scripted ego's behavior dropped from each scene (:attr:`Prepared.scripted_ego`), where
    the simulate stage ran it just before; and ``within``: a prepared world with the same
    actors and more, where this world's program is that one's without the extra actors: its
    compiled program, their objects left out of each scene (:attr:`Prepared.leave_out`)."""
    from regen.driving.grounding.rules import plans_for
    from regen.driving.simulation.run import compile_program
    from regen.driving.simulation.scenario import map_name, timing
    from regen.driving.world.maps import ensure_map

    template, scripted_plans = plans_for(scenario)
    plans = [dataclasses.replace(p, scenic_behavior="", schedule=[]) if p.name == "ego" else p
             for p in scripted_plans]
    dt, steps, seed = timing(scenario)
    name = map_name(scenario)
    map_path = str(ensure_map(name))
    text = _program(scenario, plans)
    t0 = time.perf_counter()
    leave_out = _shared(within, plans, text) if within is not None and text not in _COMPILED else None
    scripted_ego = False
    if leave_out is not None:
        compiled, scripted_ego = within.compiled, within.scripted_ego
    else:
        leave_out = frozenset()
        compiled = _scripted(scenario, scripted_plans, text) if text not in _COMPILED else None
        if compiled is not None:
            scripted_ego = True
        else:
            if text not in _COMPILED:
                if len(_COMPILED) >= 16:
                    _COMPILED.pop(next(iter(_COMPILED)))
                _COMPILED[text] = compile_program(text)
            compiled = _COMPILED[text]
    return Prepared(scenario=scenario, plans=plans, template=template, compiled=compiled,
                    dt=dt, steps=steps, seed=seed, map_name=name, map_path=map_path,
                    compile_time=time.perf_counter() - t0, leave_out=leave_out,
                    scripted_ego=scripted_ego)


def _at(schedule: list[tuple[float, str]], t: float) -> str | None:
    val = None
    for t_from, v in schedule:
        if t >= t_from - 1e-9:
            val = v
    return val


class _Driver:
    """The Python side of the loop: observes the Scenic objects, asks the policy, records."""

    def __init__(self, prep: Prepared, policy: Callable, step_timeout: float | None):
        self.prep, self.policy, self.step_timeout = prep, policy, step_timeout
        self.by_name = {p.name: p for p in prep.plans}
        t = prep.template
        self.route = list(t.route)
        self.route_idx = 0
        self.cruise = max([t.speed0] + [s for _, s, _ in t.schedule])
        self.log: list[list[tuple[float, float, float, float]]] = []
        self.names: list[str] = []
        self.policy_time = 0.0
        self.t_fire: dict[str, float | None] = {}  # actor -> when its trigger fired [s]
        # the ego's sensors whose signal degrades: the policy observes what they perceive
        self.sensors = [(p, eff) for p in prep.plans if (eff := effect_of(p)) is not None]

    # recording, as regen.driving.simulation.run does
    def record(self, sim) -> None:
        if not self.names:
            self.names = [getattr(o, "name", f"obj{i}") for i, o in enumerate(sim.objects)]
        self.log.append(snapshot(sim.objects))

    def _route_ahead(self, x: float, y: float, h: float) -> tuple[tuple[float, float], ...]:
        c, s = math.cos(h), math.sin(h)
        r = self.route
        while self.route_idx < len(r) - 1 and (
                (r[self.route_idx][0] - x) * c + (r[self.route_idx][1] - y) * s < 0.5):
            self.route_idx += 1
        out = []
        for px, py in r[self.route_idx:]:
            if math.hypot(px - x, py - y) > ROUTE_AHEAD:
                break
            out.append((px, py))
        return tuple(out)

    def _perceived(self, t: float, ego_now) -> tuple[float, float]:
        """(GNSS position error [m], share of the camera's view lost) the ego perceives at ``t``."""
        out = {"gnss_signal": 0.0, "camera_view": 0.0}
        for p, eff in self.sensors:
            clock = t
            if p.trigger is not None and ego_now is not None:
                self.t_fire[p.name], clock = warped_time(p.trigger.spec(), self.t_fire.get(p.name), t, *ego_now)
            out[eff.key] = perceived_error(clock - eff.t_switch, eff.rate, eff.magnitude, eff.base)
        return out["gnss_signal"], out["camera_view"]

    def observe(self, sim) -> Observation:
        """What the policy sees: the ego where its GNSS puts it (off to its left by the perceived
        error of a degraded receiver) and no actor ahead while its camera has lost more than
        half its view (:mod:`regen.driving.world.sensing`)."""
        t = sim.currentTime * self.prep.dt
        actors = []
        ego = None
        eo = sim.objects[self.names.index("ego")] if "ego" in self.names else None
        ego_now = ((float(eo.position.x), float(eo.position.y), float(math.hypot(eo.velocity.x, eo.velocity.y)))
                   if eo is not None else None)
        gnss_error, view_lost = self._perceived(t, ego_now)
        for i, o in enumerate(sim.objects):
            name = self.names[i]
            h = float(o.heading) + math.pi / 2  # Scenic measures headings from +y
            if name == "ego":
                px = float(o.position.x) - math.sin(h) * gnss_error if self.sensors else float(o.position.x)
                py = float(o.position.y) + math.cos(h) * gnss_error if self.sensors else float(o.position.y)
                ego = EgoState(x=px, y=py, heading=math.atan2(math.sin(h), math.cos(h)),
                               speed=float(math.hypot(o.velocity.x, o.velocity.y)),
                               length=float(o.length), width=float(o.width), cruise_speed=self.cruise,
                               route_ahead=self._route_ahead(px, py, h))
                continue
            p = self.by_name.get(name)
            if p is None or not p.cls:
                continue
            clock = t
            if p.trigger is not None and ego_now is not None:
                self.t_fire[name], clock = warped_time(p.trigger.spec(), self.t_fire.get(name), t, *ego_now)
            vis = {k: _at(p.states[k], clock) for k in VISIBLE if k in p.states}
            if p.cls == "Car" and p.kind != "object" and len(self.log) >= 2:
                decel = (self.log[-2][i][3] - self.log[-1][i][3]) / self.prep.dt
                broken = p.states.get("brake_lights", [(0.0, "")])[-1][1] == "broken"
                vis["brake_lights"] = "on" if decel > BRAKE_LIGHT_DECEL and not broken else "off"
            actors.append(ActorState(name=name, category=actor_category(p.asset, p.kind), asset=p.asset,
                                     x=float(o.position.x), y=float(o.position.y),
                                     heading=math.atan2(math.sin(h), math.cos(h)),
                                     vx=float(o.velocity.x), vy=float(o.velocity.y),
                                     length=p.length, width=p.width, **vis))
        if ego is None:
            raise SimulationError("the Scenic program has no object named 'ego'")
        if view_lost > LIMITS["camera_view"] and eo is not None:  # the camera sees nothing ahead
            c, s = math.cos(ego.heading), math.sin(ego.heading)
            actors = [a for a in actors if (a.x - eo.position.x) * c + (a.y - eo.position.y) * s <= 0.0]
        return Observation(t=round(t, 6), dt=self.prep.dt, ego=ego, actors=tuple(actors))

    def act(self, sim) -> None:
        """Ask the policy and set the ego's controls; PolicyFailure on any fault of the policy."""
        obs = self.observe(sim)
        t0 = time.perf_counter()
        raw = _call_with_timeout(self.policy, obs, self.step_timeout)
        self.policy_time += time.perf_counter() - t0
        try:
            action = as_action(raw)
        except ValueError as exc:
            raise PolicyFailure("invalid_action", str(exc)) from None
        ego = sim.objects[self.names.index("ego")]
        a = action.acceleration
        ego.throttle = min(1.0, a / MAX_ACCEL) if a > 0 else 0.0
        ego.brake = min(1.0, -a / MAX_BRAKE) if a < 0 else 0.0
        # Newtonian: heading rate = -speed * sin(steer * pi/2) / length; we want speed * curvature
        k = max(-1.0, min(1.0, action.curvature * float(ego.length)))
        ego.steer = -math.asin(k) * 2.0 / math.pi


@functools.cache
def _simulator_class():
    from regen.driving.simulation.run import scenic_modules

    _, newtonian = scenic_modules()

    class PolicySimulation(newtonian.NewtonianSimulation):
        def __init__(self, scene, network, driver, **kwargs):
            self.regen_driver = driver  # before super().__init__: it runs the whole simulation
            super().__init__(scene, network, False, False, False, **kwargs)

        def setup(self):
            super().setup()
            self.regen_driver.record(self)

        def step(self):
            self.regen_driver.act(self)
            super().step()
            self.regen_driver.record(self)

        def getProperties(self, obj, properties):
            return object_properties(self, obj, properties)

        def updateObjects(self):
            update_objects(self)

    class PolicySimulator(newtonian.NewtonianSimulator):
        def __init__(self, driver):
            super().__init__()
            self.regen_driver = driver

        def createSimulation(self, scene, **kwargs):
            return PolicySimulation(scene, self.network, self.regen_driver, **kwargs)

    return PolicySimulator


def _compiled_here(prep: Prepared) -> Prepared:
    """``prep`` with its world's own program compiled (no other program's objects to leave out,
    no behavior to drop)."""
    from regen.driving.simulation.run import compile_program

    text = _program(prep.scenario, prep.plans)
    return dataclasses.replace(prep, compiled=compile_program(text), leave_out=frozenset(), scripted_ego=False)


def run_policy(scenario: Scenario | Prepared, policy: Callable, *,
               step_timeout: float | None = STEP_TIMEOUT, steps: int | None = None) -> Episode:
    """Simulate ``scenario`` with its ego driven by ``policy`` (see :mod:`regen.driving.testing.policies`).

    ``step_timeout`` [s] per policy call (None: no limit, no thread); ``steps`` overrides the
    scenario's duration. Policy faults end the episode with ``failure`` set; scenario and
    simulator faults raise :class:`~regen.errors.SimulationError` as in the normal pipeline.
    """
    from regen.driving.simulation.record import build_trace
    from regen.driving.simulation.run import quiet_behaviors, raw_run
    from regen.driving.world.maps import geometry

    prep = scenario if isinstance(scenario, Prepared) else prepare(scenario)
    n_steps = int(steps if steps is not None else prep.steps)
    try:
        reset_policy(policy, step_timeout)
    except PolicyFailure as exc:
        return Episode(trace=None, failure=exc.reason, failure_kind=exc.kind, failure_time=0.0,
                       timings={"compile": prep.compile_time})
    driver = _Driver(prep, policy, step_timeout)
    random.seed(prep.seed)
    np.random.seed(prep.seed)
    try:
        scene, _ = prep.compiled.generate(maxIterations=1, verbosity=0)
    except Exception as exc:
        if prep.leave_out or prep.scripted_ego:  # another world's program failed: this one's own decides
            own = _compiled_here(prep)
            return run_policy(own, policy, step_timeout=step_timeout, steps=steps)
        raise SimulationError(f"Scenic could not place the actors: {type(exc).__name__}: {exc}") from exc
    if prep.leave_out:  # the simulation binds to the scene's objects as it starts
        scene.objects = tuple(o for o in scene.objects if o.name not in prep.leave_out)
    if prep.scripted_ego:  # the scene's own objects: the compiled program keeps its ego's behavior
        scene.egoObject.behavior = None
    failure: PolicyFailure | None = None
    t0 = time.perf_counter()
    try:
        with quiet_behaviors():
            sim = _simulator_class()(driver).simulate(scene, maxSteps=n_steps, timestep=prep.dt,
                                                       verbosity=0, raiseGuardViolations=False)
        if sim is None:
            raise SimulationError("the Newtonian simulation was rejected (a requirement failed)")
    except PolicyFailure as exc:
        failure = exc
    except SimulationError:
        raise
    except Exception as exc:
        raise SimulationError(f"the Newtonian simulation failed: {type(exc).__name__}: {exc}") from exc
    t1 = time.perf_counter()
    timings = {"compile": prep.compile_time, "simulate": t1 - t0, "policy": driver.policy_time}
    if not driver.log:
        return Episode(trace=None, failure=failure.reason if failure else "nothing was simulated",
                         failure_kind=failure.kind if failure else "exception", failure_time=0.0,
                         timings=timings)
    run = raw_run(driver.log, driver.names, prep.dt, {})
    trace = build_trace(run, prep.plans, geometry(prep.map_name), map_path=prep.map_path,
                        seed=prep.seed, meta={"scenario": prep.scenario.id, "ego": "policy"})
    return Episode(trace=trace, failure=failure.reason if failure else None,
                     failure_kind=failure.kind if failure else None,
                     failure_time=run.times[-1] if failure else None,
                     steps=len(driver.log) - 1, timings=timings)


__all__ = ["STEP_TIMEOUT", "PolicyFailure", "Episode", "Prepared", "prepare", "run_policy"]
