"""The Panda's hand set-point: inverse kinematics towards a target pose, bounded joint torques,
straight-line moves of the end effector and the finger width.

:class:`Arm` is the motion layer under :class:`~regen.manipulation.simulation.controller.Controller`
(which adds grasps and joint following); the SAC policy and the policy loop move its ``target``
directly.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from regen.manipulation.simulation.layout import ARM_JOINTS, EE_LINK, FINGER_JOINTS, PANDA_HOME
from regen.manipulation.simulation.scene import Scene
from regen.manipulation.world.furniture import Vec3

CONTROL_EVERY = 4  # physics steps per IK update (60 Hz control at 240 Hz physics)
ARM_FORCE = 87.0  # [N m] Panda joint torque limit
MOVE_SPEED = 0.35  # [m/s] end-effector set-point speed


def orientation(p, approach: str) -> tuple[float, float, float, float]:
    """The hand's orientation (quaternion) for an approach: 'top' points the gripper down,
    'front' along +x (into furniture fronts)."""
    if approach == "front":
        return tuple(p.getQuaternionFromEuler((0.0, math.pi / 2, 0.0)))
    return tuple(p.getQuaternionFromEuler((math.pi, 0.0, 0.0)))


class Arm:
    """Moves the hand of a :class:`Scene`'s robot; ``on_step`` is called after every physics
    step. ``target`` is the hand's set-point [m]; ``approach`` its orientation."""

    def __init__(self, scene: Scene, on_step: Callable[[], None] | None = None):
        self.scene = scene
        self.p = scene.p
        self.on_step = on_step or (lambda: None)
        self.approach = "top"
        self.target = np.array(scene.ee_position())
        self._fingers = 0.04
        self.steps = 0
        # the joint targets of the last update (7 arm [rad], 2 fingers [m]): the action a
        # recorded trace keeps (regen.manipulation.simulation.record)
        self.command: list[float] = [*PANDA_HOME, 0.04, 0.04]
        n = 9
        lower = [-2.9, -1.76, -2.9, -3.07, -2.9, -0.017, -2.9, 0.0, 0.0]
        upper = [2.9, 1.76, 2.9, -0.07, 2.9, 3.75, 2.9, 0.04, 0.04]
        self._ik_kw = dict(lowerLimits=lower, upperLimits=upper,
                           jointRanges=[u - lo for u, lo in zip(upper, lower, strict=True)],
                           restPoses=[*PANDA_HOME, 0.04, 0.04], maxNumIterations=40,
                           residualThreshold=1e-4)
        assert len(lower) == n

    # --- low level ----------------------------------------------------------------------------

    def _apply(self) -> None:
        p, s = self.p, self.scene
        orn = orientation(p, self.approach)
        q = p.calculateInverseKinematics(s.robot, EE_LINK, self.target.tolist(), orn,
                                         physicsClientId=s.client, **self._ik_kw)
        p.setJointMotorControlArray(s.robot, list(ARM_JOINTS), p.POSITION_CONTROL,
                                    targetPositions=list(q[:7]), forces=[ARM_FORCE] * 7,
                                    physicsClientId=s.client)
        self.command = [*(float(v) for v in q[:7]), self._fingers, self._fingers]
        p.setJointMotorControlArray(s.robot, list(FINGER_JOINTS), p.POSITION_CONTROL,
                                    targetPositions=[self._fingers] * 2, forces=[20.0] * 2,
                                    physicsClientId=s.client)

    def tick(self, n: int = CONTROL_EVERY) -> None:
        """Update the IK command and advance ``n`` physics steps."""
        self._apply()
        for _ in range(n):
            self.scene.step()
            self.steps += 1
            self.on_step()

    def wait(self, seconds: float) -> None:
        for _ in range(max(1, int(seconds / (CONTROL_EVERY / 240.0)))):
            self.tick()

    # --- moves --------------------------------------------------------------------------------

    def move_to(self, target: Vec3, *, approach: str | None = None, speed: float = MOVE_SPEED,
                tol: float = 0.015, timeout: float = 4.0) -> bool:
        """Move the end effector in a straight line to ``target`` [m]; True when reached."""
        if approach:
            self.approach = approach
        goal = np.asarray(target, dtype=float)
        step = speed * CONTROL_EVERY / 240.0
        for _ in range(int(timeout * 240 / CONTROL_EVERY)):
            delta = goal - self.target
            dist = float(np.linalg.norm(delta))
            self.target = goal.copy() if dist <= step else self.target + delta / dist * step
            self.tick()
            if dist <= step and np.linalg.norm(np.asarray(self.scene.ee_position()) - goal) < tol:
                return True
        return False

    def set_fingers(self, width: float) -> None:
        self._fingers = width


__all__ = ["ARM_FORCE", "CONTROL_EVERY", "MOVE_SPEED", "Arm", "orientation"]
