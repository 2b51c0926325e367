"""What a manipulation policy sees and returns.

A policy is any callable ``policy(observation: Observation) -> Action``; a sequence or array
``(dx, dy, dz)`` or ``(dx, dy, dz, gripper)`` is accepted too. An object with a ``reset()``
method has it called at the start of every episode.

**Timing.** The policy is called at :data:`CONTROL_HZ` (20 Hz, every :data:`POLICY_DT` = 0.05 s
of simulated time, 12 PyBullet steps of 1/240 s). The episode lasts the scenario's duration
(``ManipulationWorld.duration``, 12 s), or less when the policy returns ``done=True``.

**Action** (:class:`Action`): a displacement ``(dx, dy, dz)`` [m] of the end-effector set-point
in the world frame (x away from the robot base, z up), each component clipped to
±:data:`MAX_STEP` (0.03 m per step, 0.6 m/s); the set-point is also kept inside
:data:`WORKSPACE` and within :data:`LEASH` of the hand (a blocked arm does not wind up). The
arm follows the set-point through inverse kinematics with the Panda's torque limits; the
hand's orientation is fixed by the task (``observation.task.approach``: 'top' points the
fingers down, 'front' along +x). ``gripper`` above 0.5 closes the hand, else it opens it.
Closing grasps (as the scripted controller does, with a constraint) the nearest graspable
part within :data:`GRASP_RADIUS` of the fingertip point at the moment the hand closes: the
task object's handle, the task item, a bucket's bar; closing on nothing leaves a closed empty
hand (to press a switch). Opening lets go. A NaN, an infinity or a wrong shape is a policy
fault that ends the episode.

**Observation** (:class:`Observation`): time, the robot (joint positions and velocities, hand
pose, set-point, gripper state), every object (pose, size, role, articulation state) and the
task (behavior, its text, the narrative and each context object's relation).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

CONTROL_HZ = 20  # policy calls per simulated second
POLICY_DT = 1.0 / CONTROL_HZ  # [s]
MAX_STEP = 0.03  # [m] largest set-point displacement per axis and step
LEASH = 0.05  # [m] the set-point stays this close to the hand
GRASP_RADIUS = 0.05  # [m] a closing hand grasps a part within this distance
GRIPPER_CLOSE = 0.5  # a gripper command above this closes the hand
WORKSPACE = ((-0.2, -0.85, 0.02), (0.9, 0.85, 1.2))  # set-point box [m], world frame

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # (x, y, z, w)


@dataclass(frozen=True, kw_only=True)
class RobotState:
    """The Franka Panda (base at the world origin)."""

    q: tuple[float, ...]  # 9 joint positions: 7 arm joints [rad], 2 finger joints [m]
    qd: tuple[float, ...]  # 9 joint velocities [rad/s, m/s]
    ee_position: Vec3  # fingertip point (panda_grasptarget) [m], world frame
    ee_orientation: Quat  # hand orientation, quaternion (x, y, z, w)
    ee_target: Vec3  # the set-point the arm follows [m]; actions move it
    gripper_width: float  # finger opening [m], 0 (closed) .. 0.08 (open)
    gripper_closed: bool  # the last gripper command
    holding: str | None  # the grasped body, if any


@dataclass(frozen=True, kw_only=True)
class Articulation:
    """The moving joint of a piece of furniture (door hinge, drawer slide, switch)."""

    joint_type: str  # 'revolute' or 'prismatic'
    position: float  # joint value [rad or m]
    fraction: float  # 0 closed / off .. 1 fully open / on
    axis: Vec3  # joint axis, unit vector, world frame
    origin: Vec3  # a point on the axis (the moving link's origin) [m]
    closed: float  # joint value when closed / off [rad or m]
    opened: float  # joint value when fully open / on [rad or m]
    handle: Vec3 | None  # the handle point [m], None without a handle


@dataclass(frozen=True, kw_only=True)
class ObjectState:
    """Every body but the robot: furniture, the task item, context objects."""

    name: str  # entity name, e.g. 'door1', 'pet1'
    asset: str  # asset database id
    role: str  # 'target' (what the task acts on), 'item', 'support' (table) or 'context'
    living: bool  # a person or a pet: the arm must never touch it
    position: Vec3  # centre of its bounding box [m]
    orientation: Quat  # base orientation (x, y, z, w)
    size: Vec3  # bounding-box extents (x, y, z) [m]
    articulation: Articulation | None = None
    interior: tuple[Vec3, Vec3] | None = None  # furniture interior box (lo, hi) [m], moves with a drawer


@dataclass(frozen=True, kw_only=True)
class Task:
    """What the robot is to do and the context it does it in."""

    behavior: str  # behavior id, e.g. 'open_door'
    text: str  # e.g. 'the robot opens the door'
    narrative: str  # why, in the scenario's words
    context: tuple[str, ...]  # each context object's placement, e.g. 'pet1 outside door1'
    target: str  # the furniture the task acts on
    item: str | None  # the object a pick-and-place task moves
    goal_fraction: float | None  # joint tasks: the opening the scripted robot drives to
    goal_xy: tuple[float, float] | None  # where a retrieved or carried item is put down [m]
    approach: str  # hand orientation: 'top' (fingers down) or 'front' (fingers along +x)


@dataclass(frozen=True, kw_only=True)
class Observation:
    t: float  # simulated time [s]
    dt: float  # time between policy calls [s]
    robot: RobotState
    objects: tuple[ObjectState, ...]
    task: Task

    def object(self, name: str) -> ObjectState:
        for o in self.objects:
            if o.name == name:
                return o
        raise KeyError(name)


@dataclass(frozen=True)
class Action:
    dx: float = 0.0  # [m] set-point displacement, clipped to +-MAX_STEP
    dy: float = 0.0  # [m]
    dz: float = 0.0  # [m]
    gripper: float = 0.0  # > GRIPPER_CLOSE closes the hand, else it opens
    done: bool = False  # end the episode (the robot has finished)

    @property
    def delta(self) -> np.ndarray:
        """The clipped displacement [m]."""
        return np.clip(np.array([self.dx, self.dy, self.dz], dtype=float), -MAX_STEP, MAX_STEP)


def as_action(value: object) -> Action:
    """A policy's return value as an Action; ValueError naming what is wrong (NaN, shape)."""
    if isinstance(value, Action):
        nums: Sequence = (value.dx, value.dy, value.dz, value.gripper)
        done = bool(value.done)
    elif isinstance(value, (tuple, list, np.ndarray)):
        arr = np.asarray(value, dtype=object).reshape(-1) if not isinstance(value, np.ndarray) else value
        if getattr(arr, "ndim", 1) != 1 or len(arr) not in (3, 4):
            shape = getattr(arr, "shape", (len(arr),))
            raise ValueError(f"the policy's action has shape {tuple(shape)}, not (3,) or (4,): "
                             "(dx, dy, dz[, gripper])")
        nums, done = list(arr), False
    else:
        raise ValueError(f"the policy returned {type(value).__name__}, not an Action or a "
                         "(dx, dy, dz[, gripper]) sequence")
    try:
        vals = [float(v) for v in nums]
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"the policy's action is not numeric: {value!r}") from exc
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"the policy's action is not finite: {vals}")
    return Action(*vals[:3], gripper=vals[3] if len(vals) == 4 else 0.0, done=done)


__all__ = ["CONTROL_HZ", "GRASP_RADIUS", "GRIPPER_CLOSE", "LEASH", "MAX_STEP", "POLICY_DT", "WORKSPACE",
           "Action", "Articulation", "ObjectState", "Observation", "RobotState", "Task", "as_action"]
