"""Roll a grounded manipulation scenario out in PyBullet and record a :class:`Trace`.

Scenario conventions (written by :mod:`regen.manipulation.grounding.ground`):

- ``world`` (:class:`~regen.manipulation.world.setting.ManipulationWorld`): ``behavior`` (the
  task's id); ``duration`` [s] caps the rollout.
- entity ``properties['role']``: ``robot``, ``target`` (the furniture the behavior acts on),
  ``item`` (the object it moves), ``support`` (the table) or ``context`` (placed objects).
- ``parameters[name]``: ``x``, ``y`` [m] (furniture origin / object bottom centre), ``z`` [m]
  (support height), ``furniture`` (kind), ``fraction`` (initial opening), ``length``,
  ``width``, ``height`` [m], ``dynamic`` (bool).

What the trace holds is said in :mod:`regen.manipulation.simulation.record`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.errors import SimulationError
from regen.manipulation.simulation.layout import FurniturePlacement, ObjectPlacement, SceneLayout
from regen.manipulation.simulation.record import Recorder
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.setting import ManipulationWorld
from regen.manipulation.world.tasks import BehaviorDef, get_behavior

log = logging.getLogger(__name__)


@dataclass
class Roles:
    target: str
    item: str | None = None
    behavior: BehaviorDef | None = None


def layout_from_scenario(scenario: Scenario) -> tuple[SceneLayout, Roles]:
    """The physical layout a scenario describes, and which entity plays which role."""
    behavior = get_behavior(ManipulationWorld.of(scenario).behavior)
    layout = SceneLayout()
    target: str | None = None
    item: str | None = None
    for e in scenario.entities:
        role = e.properties.get("role", "context")
        if role == "robot":
            continue
        par = scenario.parameters.get(e.name)
        if par is None:
            raise SimulationError(f"entity {e.name!r} has no solved placement; ground the scenario first")
        if "furniture" in par:
            layout.furniture.append(FurniturePlacement(e.name, str(par["furniture"]), float(par["x"]),
                                                       float(par["y"]), float(par.get("fraction", 0.0))))
        else:
            layout.objects.append(ObjectPlacement(
                e.name, e.asset, float(par["x"]), float(par["y"]), float(par.get("z", 0.0)),
                (float(par["length"]), float(par["width"]), float(par["height"])),
                dynamic=bool(par.get("dynamic", False)), label=e.name,
                power=str(par["power"]) if par.get("power") else None))
        if role == "target":
            target = e.name
        elif role == "item":
            item = e.name
    if target is None:
        raise SimulationError("the scenario has no target furniture (an entity with role 'target')")
    return layout, Roles(target, item, behavior)


@dataclass
class RolloutResult:
    trace: Trace
    timings: dict[str, float]  # stage -> wall seconds (build, rollout)
    script_ok: bool  # every primitive reported success (the verdict is still the FSM's)
    physics_steps: int


def rollout(scenario: Scenario, *, policy: object | None = None,
            watch: tuple[str, ...] = ()) -> RolloutResult:
    """Build the scene, run the behavior's controller, record the trace.

    ``policy``: a trained SAC policy (:mod:`regen.manipulation.simulation.sac`); default is the
    scripted motion-primitive controller. ``watch``: bodies whose contacts with the robot the
    trace records (see :mod:`regen.manipulation.simulation.record`). Simulator failures raise
    :class:`SimulationError`.
    """
    from regen.manipulation.simulation.controller import Controller
    from regen.manipulation.simulation.scripted import run_script

    layout, roles = layout_from_scenario(scenario)
    behavior = roles.behavior
    assert behavior is not None
    t0 = time.perf_counter()
    with Scene(layout) as scene:
        t1 = time.perf_counter()
        rec = Recorder(scene, watch=tuple(watch))
        if behavior.state_name:
            rec.meaning[roles.target] = behavior.state_name
        ctl = Controller(scene, on_step=rec)
        # the recorder reads the controller's grasp state on every sample
        orig = ctl.on_step

        def on_step() -> None:
            rec.holding = ctl.holding
            rec.command = ctl.command
            orig()

        ctl.on_step = on_step
        ctl.wait(0.25)  # let dynamic bodies settle before the behavior starts
        try:
            if policy is not None:
                from regen.manipulation.simulation.sac import run_policy

                ok = run_policy(policy, ctl, behavior, roles.target)
            else:
                ok = run_script(ctl, behavior, roles.target, roles.item)
        except SimulationError:
            raise
        except Exception as exc:  # pybullet raises bare errors; report them as ours
            raise SimulationError(f"PyBullet failed during the rollout: {exc}") from exc
        rec.holding = ctl.holding
        rec.command = ctl.command
        rec.sample()
        trace = rec.trace(scenario)
        t2 = time.perf_counter()
    return RolloutResult(trace, {"build": t1 - t0, "rollout": t2 - t1}, ok, rec.steps)


__all__ = ["Roles", "RolloutResult", "layout_from_scenario", "rollout"]
