"""Motion primitives for the Panda: IK moves, handle grasps, joint following, pick and place.

Grasping is a PyBullet constraint, not finger friction: a point-to-point constraint at the
handle (so the handle can turn in the hand as a door swings) or a fixed constraint on a picked
object. Physical finger grasps of thin handles are unreliable in PyBullet and would make the
verdicts measure grasp luck instead of the scenario; the fingers still close for the pictures.
Everything else is physics: the arm is position-controlled through IK with bounded torques, the
furniture joints have friction, and a joint moves only because the arm drags it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from regen.manipulation.scene import ARM_JOINTS, EE_LINK, FINGER_JOINTS, PANDA_HOME, Scene, Vec3

CONTROL_EVERY = 4  # physics steps per IK update (60 Hz control at 240 Hz physics)
ARM_FORCE = 87.0  # [N m] Panda joint torque limit
GRASP_FORCE = 300.0  # [N] strength of the grasp constraint
MOVE_SPEED = 0.35  # [m/s] end-effector set-point speed
HAND_LINKS = (7, 8, 9, 10, 11)  # link 7 .. fingers and grasp target of the Panda
JOINT_RATE = 0.5  # [rad/s] slowest rate at which a handle is dragged along its arc
LEAD = 0.03  # [m] how far ahead of the handle the set-point runs along its path


def _orientation(p, approach: str) -> tuple[float, float, float, float]:
    # 'top': gripper points down; 'front': gripper points along +x (into furniture fronts)
    if approach == "front":
        return tuple(p.getQuaternionFromEuler((0.0, math.pi / 2, 0.0)))
    return tuple(p.getQuaternionFromEuler((math.pi, 0.0, 0.0)))


class Controller:
    """Drives the robot of a :class:`Scene`; ``on_step`` is called after every physics step."""

    def __init__(self, scene: Scene, on_step: Callable[[], None] | None = None):
        self.scene = scene
        self.p = scene.p
        self.on_step = on_step or (lambda: None)
        self.approach = "top"
        self.holding: str | None = None  # name of the grasped body
        self._constraint: int | None = None
        self._target = np.array(scene.ee_position())
        self._fingers = 0.04
        self.steps = 0
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
        orn = _orientation(p, self.approach)
        q = p.calculateInverseKinematics(s.robot, EE_LINK, self._target.tolist(), orn,
                                         physicsClientId=s.client, **self._ik_kw)
        p.setJointMotorControlArray(s.robot, list(ARM_JOINTS), p.POSITION_CONTROL,
                                    targetPositions=list(q[:7]), forces=[ARM_FORCE] * 7,
                                    physicsClientId=s.client)
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

    # --- primitives ---------------------------------------------------------------------------

    def move_to(self, target: Vec3, *, approach: str | None = None, speed: float = MOVE_SPEED,
                tol: float = 0.015, timeout: float = 4.0) -> bool:
        """Move the end effector in a straight line to ``target`` [m]; True when reached."""
        if approach:
            self.approach = approach
        goal = np.asarray(target, dtype=float)
        step = speed * CONTROL_EVERY / 240.0
        for _ in range(int(timeout * 240 / CONTROL_EVERY)):
            delta = goal - self._target
            dist = float(np.linalg.norm(delta))
            self._target = goal.copy() if dist <= step else self._target + delta / dist * step
            self.tick()
            if dist <= step and np.linalg.norm(np.asarray(self.scene.ee_position()) - goal) < tol:
                return True
        return False

    def set_fingers(self, width: float) -> None:
        self._fingers = width

    def grasp_handle(self, furniture: str) -> None:
        """Close on the furniture's handle with a point-to-point constraint."""
        s, p = self.scene, self.p
        b = s.bodies[furniture]
        assert b.spec is not None
        self.release()
        ee = s.ee_position()
        link_pos, link_orn = s.link_pose(furniture, b.handle_link)
        inv_pos, inv_orn = p.invertTransform(link_pos, link_orn)
        local, _ = p.multiplyTransforms(inv_pos, inv_orn, ee, (0, 0, 0, 1))
        self._constraint = p.createConstraint(s.robot, EE_LINK, b.id, b.handle_link,
                                              p.JOINT_POINT2POINT, (0, 0, 0), (0, 0, 0), local,
                                              physicsClientId=s.client)
        p.changeConstraint(self._constraint, maxForce=GRASP_FORCE, physicsClientId=s.client)
        self.holding = furniture
        self._fingers = 0.01
        self._hand_collisions(furniture, False)

    def grasp_object(self, name: str) -> None:
        """Hold a free body rigidly where it is relative to the hand (fixed constraint)."""
        s, p = self.scene, self.p
        b = s.bodies[name]
        self.release()
        ee_state = p.getLinkState(s.robot, EE_LINK, physicsClientId=s.client)
        ee_pos, ee_orn = ee_state[4], ee_state[5]
        obj_pos, obj_orn = p.getBasePositionAndOrientation(b.id, physicsClientId=s.client)
        inv_pos, inv_orn = p.invertTransform(ee_pos, ee_orn)
        rel_pos, rel_orn = p.multiplyTransforms(inv_pos, inv_orn, obj_pos, obj_orn)
        # the base inertial frame may be offset from the URDF origin (meshes); account for it
        dyn = p.getDynamicsInfo(b.id, -1, physicsClientId=s.client)
        com_pos, com_orn = dyn[3], dyn[4]
        rel_com, rel_com_orn = p.multiplyTransforms(rel_pos, rel_orn, com_pos, com_orn)
        self._constraint = p.createConstraint(s.robot, EE_LINK, b.id, -1, p.JOINT_FIXED, (0, 0, 0),
                                              rel_com, (0, 0, 0), parentFrameOrientation=rel_com_orn,
                                              childFrameOrientation=(0, 0, 0, 1),
                                              physicsClientId=s.client)
        p.changeConstraint(self._constraint, maxForce=GRASP_FORCE, physicsClientId=s.client)
        self.holding = name
        self._fingers = 0.01
        self._hand_collisions(name, False)

    def _hand_collisions(self, name: str, enable: bool) -> None:
        # The constraint is the grasp; fingers closing on the held part would fight it.
        s, p = self.scene, self.p
        bid = s.bodies[name].id
        for link in range(-1, p.getNumJoints(bid, physicsClientId=s.client)):
            for hand in HAND_LINKS:
                p.setCollisionFilterPair(s.robot, bid, hand, link, int(enable),
                                         physicsClientId=s.client)

    def ignore_contacts(self, name: str) -> None:
        """Let the hand pass through ``name`` until the next release (open fingers straddle it)."""
        self._hand_collisions(name, False)
        self._ignored = name

    def release(self) -> None:
        ignored = getattr(self, "_ignored", None)
        if ignored is not None and ignored != self.holding:
            self._hand_collisions(ignored, True)
        self._ignored = None
        if self.holding is not None:
            self._hand_collisions(self.holding, True)
        if self._constraint is not None:
            self.p.removeConstraint(self._constraint, physicsClientId=self.scene.client)
            self._constraint = None
        self.holding = None
        self._fingers = 0.04

    def follow_joint(self, furniture: str, fraction: float, *, rate: float = JOINT_RATE,
                     timeout: float = 6.0, stall: float = 1.5) -> bool:
        """Drag the held handle along its joint's path until the joint reaches ``fraction``
        (0 closed .. 1 open). Closed loop: each update aims at where the handle would be a small
        joint increment further on. False on timeout or when the joint stops moving."""
        s, p = self.scene, self.p
        b = s.bodies[furniture]
        assert b.spec is not None and b.joint is not None
        spec = b.spec
        goal = spec.closed + fraction * (spec.opened - spec.closed)
        info = p.getJointInfo(b.id, b.joint, physicsClientId=s.client)
        kind, axis_local = info[2], np.asarray(info[13], dtype=float)
        best, since = abs(goal - s.joint_position(furniture)), 0
        for _ in range(int(timeout * 240 / CONTROL_EVERY)):
            q = s.joint_position(furniture)
            err = goal - q
            if abs(err) < (0.02 if kind == p.JOINT_REVOLUTE else 0.004):
                return True
            pos, orn = s.link_pose(furniture, b.handle_link)
            rot = np.asarray(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
            axis = rot @ axis_local
            axis = axis / np.linalg.norm(axis)
            ee = np.asarray(s.ee_position())
            if kind == p.JOINT_REVOLUTE:
                arm = ee - np.asarray(pos)
                radius = max(float(np.linalg.norm(arm - axis * np.dot(arm, axis))), 0.02)
                # aim a few centimetres ahead on the arc: IK tracking error must not eat the lead
                dq = math.copysign(min(abs(err) + 0.03, max(LEAD / radius, rate / 60.0)), err)
                self._target = np.asarray(pos) + _rotate(arm, axis, dq)
            else:
                self._target = ee + axis * math.copysign(min(abs(err) + 0.01, LEAD), err)
            self.tick()
            now = abs(goal - s.joint_position(furniture))
            if now < best - 1e-3:
                best, since = now, 0
            else:
                since += 1
                if since * CONTROL_EVERY / 240.0 > stall:
                    return False
        return False

    def retreat(self, dz: float = 0.12) -> bool:
        """Let go and back off along the approach direction."""
        self.release()
        ee = np.asarray(self.scene.ee_position())
        back = np.array([-dz, 0, 0]) if self.approach == "front" else np.array([0, 0, dz])
        return self.move_to(tuple(ee + back), timeout=2.0)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues rotation of vector ``v`` about unit ``axis`` by ``angle`` [rad]."""
    axis = axis / np.linalg.norm(axis)
    c, s_ = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s_ + axis * np.dot(axis, v) * (1 - c)
