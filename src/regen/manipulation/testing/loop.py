"""A manipulation policy in the loop: the Panda of a grounded scenario driven by a policy.

The scene is built as :func:`regen.manipulation.simulation.run.rollout` builds it, except that the
context objects are free bodies with plausible masses (:data:`CONTEXT_MASS`), so an arm that
pushes one displaces or knocks it over instead of meeting an immovable wall; the scripted
rollout keeps them fixed. Every :data:`~regen.manipulation.testing.types.POLICY_DT` the policy
gets an :class:`~regen.manipulation.testing.types.Observation` and its action moves the hand's
set-point and opens or closes the hand (see :mod:`regen.manipulation.testing.types`); the trace
is recorded as the scripted rollout records it, plus the robot's contacts with every context
object and each object's tilt.

A policy that raises, returns something that is not a finite action of the right shape, or
takes longer than the per-step timeout ends the episode there: the episode carries the reason
and the trace up to that step, never an exception.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.errors import SimulationError
from regen.harness.contract import Episode, Policy
from regen.harness.timeout import PolicyFailure, call_with_timeout, reset_policy
from regen.manipulation.simulation.arm import CONTROL_EVERY
from regen.manipulation.simulation.controller import Controller
from regen.manipulation.simulation.layout import ARM_JOINTS, EE_LINK, FINGER_JOINTS, SceneLayout
from regen.manipulation.simulation.record import Recorder
from regen.manipulation.simulation.run import Roles, layout_from_scenario
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.testing.types import (
    GRASP_RADIUS,
    GRIPPER_CLOSE,
    LEASH,
    POLICY_DT,
    WORKSPACE,
    Action,
    Articulation,
    ObjectState,
    Observation,
    RobotState,
    Task,
    as_action,
)
from regen.manipulation.world.setting import ManipulationWorld
from regen.manipulation.world.tasks import BehaviorDef

STEP_TIMEOUT = 1.0  # default wall time a policy may take per step [s]
SETTLE = 0.25  # [s] dynamic bodies settle before the first policy call (as the scripted rollout)
TICKS = round(POLICY_DT * 240 / CONTROL_EVERY)  # controller updates per policy step (3)
LIVING = frozenset({"pet", "child", "adult"})  # assets that are people or pets
# [kg] of free context objects: a person or a pet is heavy enough that a bump shows as a
# collision, not as a body flying off; everything else is a household object
CONTEXT_MASS = {"pet": 8.0, "child": 20.0, "adult": 70.0}
OBJECT_MASS = 0.5  # [kg]


@dataclass
class Prepared:
    """What every episode of one scenario shares: the layout, the roles and the task."""

    scenario: Scenario
    layout: SceneLayout
    roles: Roles
    behavior: BehaviorDef
    duration: float  # [s] the episode's cap (the scenario's duration)
    context: tuple[str, ...]  # context objects
    living: tuple[str, ...]  # context objects that are people or pets
    task: Task


def _approach(behavior: BehaviorDef) -> str:
    """The hand orientation the scripted controller uses for the behavior throughout."""
    from regen.manipulation.world.furniture import furniture

    if behavior.script == "articulate":
        return furniture(behavior.furniture).approach
    if behavior.script == "pick_place" and behavior.furniture == "fridge":
        return "front"  # a side grasp under the fridge's top
    return "top"


def prepare(scenario: Scenario) -> Prepared:
    """The layout with free context objects, the roles and the task text (no PyBullet yet)."""
    if scenario.solver.status == "infeasible":
        raise SimulationError("the scenario's placement is infeasible: " + "; ".join(scenario.solver.conflicts))
    layout, roles = layout_from_scenario(scenario)
    behavior = roles.behavior
    assert behavior is not None
    context = tuple(e.name for e in scenario.entities if e.properties.get("role", "context") == "context"
                    and e.name in scenario.parameters)
    for o in layout.objects:
        if o.name in context:
            o.dynamic = True
    assets = {e.name: e.asset for e in scenario.entities}
    placed = tuple(f"{e.name} {e.properties['location']}" for e in scenario.entities
                   if e.name in context and e.properties.get("location"))
    task = Task(behavior=behavior.id, text=scenario.behavior.text, narrative=scenario.narrative,
                context=placed, target=roles.target, item=roles.item,
                goal_fraction=behavior.goal_fraction if behavior.script in ("articulate", "press") else None,
                goal_xy=tuple(behavior.item.goal_xy) if behavior.item is not None and (
                    behavior.item.start == "cavity" or behavior.script == "carry") else None,
                approach=_approach(behavior))
    return Prepared(scenario=scenario, layout=layout, roles=roles, behavior=behavior,
                    duration=ManipulationWorld.of(scenario).duration, context=context,
                    living=tuple(n for n in context if assets[n] in LIVING), task=task)


class Session:
    """One live episode: ``observe()``, ``apply(action)`` ..., ``trace()``, ``close()``."""

    def __init__(self, prep: Prepared):
        self.prep = prep
        self.scene = Scene(prep.layout)
        try:
            s, p = self.scene, self.scene.p
            for name in prep.context:
                asset = s.bodies[name].asset
                p.changeDynamics(s.bodies[name].id, -1, mass=CONTEXT_MASS.get(asset, OBJECT_MASS),
                                 physicsClientId=s.client)
            self.rec = Recorder(s, watch=prep.context)
            if prep.behavior.state_name:
                self.rec.meaning[prep.roles.target] = prep.behavior.state_name
            self.ctl = Controller(s, on_step=self._on_step)
            self.ctl.approach = prep.task.approach
            self._free_item()
            self.closed = False
            self.ctl.wait(SETTLE)
        except BaseException:
            self.scene.close()
            raise
        self.roles = {e.name: e.properties.get("role", "context") for e in prep.scenario.entities}

    def _on_step(self) -> None:
        self.rec.holding = self.ctl.holding
        self.rec()

    def _free_item(self) -> None:
        # open fingers straddle the task item (the grasp is a constraint, as in the scripted run)
        if self.prep.roles.item and self.ctl.holding is None:
            self.ctl.ignore_contacts(self.prep.roles.item)

    @property
    def t(self) -> float:
        """Simulated time [s] since the scene was built (the trace's clock)."""
        return round(self.rec.steps / 240.0, 6)

    # --- observing ----------------------------------------------------------------------------

    def _articulation(self, name: str) -> Articulation | None:
        s, p = self.scene, self.scene.p
        b = s.bodies[name]
        if b.spec is None or b.joint is None:
            return None
        info = p.getJointInfo(b.id, b.joint, physicsClientId=s.client)
        pos, orn = s.link_pose(name, b.joint)
        rot = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
        axis = rot @ np.asarray(info[13], dtype=float)
        axis = axis / max(float(np.linalg.norm(axis)), 1e-9)
        return Articulation(joint_type="revolute" if info[2] == p.JOINT_REVOLUTE else "prismatic",
                            position=s.joint_position(name), fraction=s.joint_fraction(name),
                            axis=tuple(float(v) for v in axis), origin=tuple(float(v) for v in pos),
                            closed=float(b.spec.closed), opened=float(b.spec.opened),
                            handle=tuple(float(v) for v in s.handle_position(name)) if b.spec.handle_link else None)

    def _interior(self, name: str):
        cav = self.scene.cavity(name) if self.scene.bodies[name].kind == "furniture" else None
        return None if cav is None else (tuple(map(float, cav.lo)), tuple(map(float, cav.hi)))

    def observe(self) -> Observation:
        s, p, c = self.scene, self.scene.p, self.scene.client
        joints = [*ARM_JOINTS, *FINGER_JOINTS]
        states = p.getJointStates(s.robot, joints, physicsClientId=c)
        ee = p.getLinkState(s.robot, EE_LINK, computeForwardKinematics=True, physicsClientId=c)
        robot = RobotState(q=tuple(float(st[0]) for st in states), qd=tuple(float(st[1]) for st in states),
                           ee_position=tuple(float(v) for v in ee[4]),
                           ee_orientation=tuple(float(v) for v in ee[5]),
                           ee_target=tuple(float(v) for v in self.ctl.target),
                           gripper_width=float(states[-1][0] + states[-2][0]),
                           gripper_closed=self.closed, holding=self.ctl.holding)
        objects = []
        for name, b in s.bodies.items():
            if b.is_robot:
                continue
            box = s.aabb(name)
            _, orn = p.getBasePositionAndOrientation(b.id, physicsClientId=c)
            objects.append(ObjectState(
                name=name, asset=b.asset, role=self.roles.get(name, "context"),
                living=name in self.prep.living,
                position=tuple((lo + hi) / 2 for lo, hi in zip(box.lo, box.hi, strict=True)),
                orientation=tuple(float(v) for v in orn), size=box.size,
                articulation=self._articulation(name) if b.kind == "furniture" else None,
                interior=self._interior(name)))
        return Observation(t=self.t, dt=POLICY_DT, robot=robot, objects=tuple(objects), task=self.prep.task)

    # --- acting -------------------------------------------------------------------------------

    def _grasp(self) -> None:
        """Grasp the nearest graspable part within GRASP_RADIUS, else close on nothing."""
        s, ctl = self.scene, self.ctl
        ee = np.asarray(s.ee_position())
        options: list[tuple[float, str, str]] = []
        target = self.prep.roles.target
        spec = s.bodies[target].spec
        if spec is not None and spec.handle_link:
            how = "object" if spec.dynamic else "handle"  # a bucket is carried by its bar
            options.append((float(np.linalg.norm(ee - np.asarray(s.handle_position(target)))), how, target))
        item = self.prep.roles.item
        if item:
            box = s.aabb(item)
            nearest = np.clip(ee, box.lo, box.hi)
            options.append((float(np.linalg.norm(ee - nearest)), "object", item))
        near = [o for o in options if o[0] <= GRASP_RADIUS]
        if not near:
            ctl.set_fingers(0.0)
            return
        _, how, name = min(near)
        if how == "handle":
            ctl.grasp_handle(name)
        else:
            ctl.grasp_object(name)

    def apply(self, action: Action) -> None:
        """Set the gripper, then move the set-point over one policy period (interpolated)."""
        ctl = self.ctl
        close = action.gripper > GRIPPER_CLOSE
        if close and not self.closed:
            self._grasp()
        elif not close and self.closed:
            ctl.release()
            self._free_item()
        self.closed = close
        start = np.asarray(ctl.target, dtype=float)
        goal = np.clip(start + action.delta, *WORKSPACE)
        ee = np.asarray(self.scene.ee_position())
        off = goal - ee
        dist = float(np.linalg.norm(off))
        if dist > LEASH:  # a blocked hand: the set-point waits for it
            goal = ee + off / dist * LEASH
        for k in range(1, TICKS + 1):
            ctl.target = start + (goal - start) * k / TICKS
            ctl.tick()

    def trace(self) -> Trace:
        self.rec.holding = self.ctl.holding
        self.rec.sample()
        return self.rec.trace(self.prep.scenario)

    def close(self) -> None:
        self.scene.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def run_policy(scenario: Scenario | Prepared, policy: Policy, *,
               step_timeout: float | None = STEP_TIMEOUT) -> Episode:
    """Simulate ``scenario`` with the Panda driven by ``policy`` until the scenario's duration
    or an action with ``done=True``. ``step_timeout`` [s] per policy call (None: no limit).
    Policy faults end the episode with ``failure`` set; PyBullet's own faults raise
    :class:`SimulationError`."""
    prep = scenario if isinstance(scenario, Prepared) else prepare(scenario)
    t0 = time.perf_counter()
    failure: PolicyFailure | None = None
    fail_t = None
    policy_time = 0.0
    try:
        session = Session(prep)
    except SimulationError:
        raise
    except Exception as exc:  # pybullet raises bare errors; report them as ours
        raise SimulationError(f"PyBullet could not build the scene: {exc}") from exc
    t1 = time.perf_counter()
    with session:
        try:
            reset_policy(policy, step_timeout)
            for _ in range(int(round(prep.duration / POLICY_DT))):
                obs = session.observe()
                t_call = time.perf_counter()
                raw = call_with_timeout(policy, obs, step_timeout)
                policy_time += time.perf_counter() - t_call
                try:
                    action = as_action(raw)
                except ValueError as exc:
                    raise PolicyFailure("invalid_action", str(exc)) from None
                session.apply(action)
                if action.done:
                    break
        except PolicyFailure as exc:
            failure, fail_t = exc, session.t
        except SimulationError:
            raise
        except Exception as exc:
            raise SimulationError(f"PyBullet failed during the policy's episode: {exc}") from exc
        trace = session.trace()
        steps = session.rec.steps
    t2 = time.perf_counter()
    trace = trace.model_copy(update={"meta": {**trace.meta, "scenario": prep.scenario.id, "robot": "policy"}})
    return Episode(trace=trace, failure=failure.reason if failure else None,
                   failure_kind=failure.kind if failure else None, failure_time=fail_t, steps=steps,
                   timings={"build": t1 - t0, "simulate": t2 - t1 - policy_time, "policy": policy_time})


__all__ = ["CONTEXT_MASS", "LIVING", "STEP_TIMEOUT", "Prepared", "Session", "prepare", "run_policy"]
