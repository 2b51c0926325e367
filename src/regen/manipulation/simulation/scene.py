"""A live PyBullet (DIRECT) world built from a :class:`SceneLayout`, and what it can be asked.

The layout is plain data (:mod:`regen.manipulation.simulation.layout`); the builder
(:mod:`regen.manipulation.simulation.build`) turns it into PyBullet bodies; this module owns the
client and its temporary URDF folder, and answers queries about the bodies' state (joints,
handles, boxes, the hand, contacts).
"""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path
from typing import Any

from regen.errors import SimulationError
from regen.manipulation.simulation.build import SceneBuilder
from regen.manipulation.simulation.layout import (
    ARM_JOINTS,
    EE_LINK,
    FINGER_JOINTS,
    Body,
    SceneLayout,
)
from regen.manipulation.simulation.pybullet import pybullet
from regen.manipulation.world.furniture import AABB, Vec3

log = logging.getLogger(__name__)


class Scene:
    """A live PyBullet world; use as a context manager so the client and temp files go away."""

    def __init__(self, layout: SceneLayout, *, use_meshes: bool = True):
        self.p = pybullet()
        self.layout = layout
        self._tmp = tempfile.TemporaryDirectory(prefix="regen-scene-")
        self.client = self.p.connect(self.p.DIRECT)
        self.bodies: dict[str, Body] = {}
        try:
            builder = SceneBuilder(self.p, self.client, Path(self._tmp.name))
            self.plane = builder.build(layout, use_meshes, self.bodies)
        except Exception as exc:  # a broken URDF or asset must not leave a client behind
            self.close()
            if isinstance(exc, SimulationError):
                raise
            raise SimulationError(f"could not build the PyBullet scene: {exc}") from exc

    def call(self, fn: str, *args: Any, **kw: Any) -> Any:
        """``pybullet.<fn>(*args, **kw)`` on this scene's client."""
        return getattr(self.p, fn)(*args, physicsClientId=self.client, **kw)

    # --- queries ------------------------------------------------------------------------------

    @property
    def robot(self) -> int:
        return self.bodies["robot"].id

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.call("stepSimulation")

    def joint_position(self, name: str) -> float:
        b = self.bodies[name]
        if b.joint is None:
            return 0.0
        return float(self.call("getJointState", b.id, b.joint)[0])

    def joint_fraction(self, name: str) -> float:
        b = self.bodies[name]
        return b.spec.fraction(self.joint_position(name)) if b.spec and b.joint is not None else 0.0

    def link_pose(self, name: str, link: int) -> tuple[Vec3, tuple[float, float, float, float]]:
        b = self.bodies[name]
        if link < 0:
            pos, orn = self.call("getBasePositionAndOrientation", b.id)
        else:
            st = self.call("getLinkState", b.id, link, computeForwardKinematics=True)
            pos, orn = st[4], st[5]
        return tuple(pos), tuple(orn)

    def handle_position(self, name: str) -> Vec3:
        """World position of the furniture's handle point [m]."""
        b = self.bodies[name]
        assert b.spec is not None
        pos, orn = self.link_pose(name, b.handle_link)
        if b.handle_link < 0:
            # the base frame of a URDF body is its inertial frame; our bases have it at the origin
            pass
        world, _ = self.call("multiplyTransforms", pos, orn, b.spec.handle_offset, (0, 0, 0, 1))
        return tuple(world)

    def position(self, name: str) -> Vec3:
        b = self.bodies[name]
        pos, _ = self.call("getBasePositionAndOrientation", b.id)
        return tuple(pos)

    def yaw(self, name: str) -> float:
        _, orn = self.call("getBasePositionAndOrientation", self.bodies[name].id)
        return float(self.call("getEulerFromQuaternion", orn)[2])

    def aabb(self, name: str, link: int | None = None) -> AABB:
        b = self.bodies[name]
        if link is None:
            lo, hi = self.call("getAABB", b.id, -1)
            for j in range(self.call("getNumJoints", b.id)):
                l2, h2 = self.call("getAABB", b.id, j)
                lo = [min(a, c) for a, c in zip(lo, l2, strict=True)]
                hi = [max(a, c) for a, c in zip(hi, h2, strict=True)]
        else:
            lo, hi = self.call("getAABB", b.id, link)
        return AABB(tuple(lo), tuple(hi))

    def cavity(self, name: str) -> AABB | None:
        """The furniture's interior in world coordinates now (moves with a drawer) [m]."""
        b = self.bodies[name]
        if b.spec is None or b.spec.cavity is None:
            return None
        c = b.spec.cavity
        shift = [b.origin[0], b.origin[1], 0.0]
        if b.cavity_link is not None and b.cavity_closed_link_pos is not None:
            now = self.link_pose(name, b.cavity_link)[0]
            shift = [s + n - c0 for s, n, c0 in zip(shift, now, b.cavity_closed_link_pos, strict=True)]
        return AABB(tuple(a + s for a, s in zip(c.lo, shift, strict=True)),
                    tuple(a + s for a, s in zip(c.hi, shift, strict=True)))

    def ee_position(self) -> Vec3:
        return tuple(self.call("getLinkState", self.robot, EE_LINK, computeForwardKinematics=True)[4])

    def arm_state(self) -> list[float]:
        return [float(self.call("getJointState", self.robot, j)[0])
                for j in (*ARM_JOINTS, *FINGER_JOINTS)]

    def tilt(self, name: str) -> float:
        """Angle [rad] between the body's up axis and the world's (0: upright)."""
        _, orn = self.call("getBasePositionAndOrientation", self.bodies[name].id)
        m = self.call("getMatrixFromQuaternion", orn)
        return float(math.acos(max(-1.0, min(1.0, m[8]))))

    def contact(self, a: str, b: str) -> bool:
        return bool(self.call("getContactPoints", self.bodies[a].id, self.bodies[b].id))

    # --- lifetime -----------------------------------------------------------------------------

    def close(self) -> None:
        if getattr(self, "client", None) is not None:
            try:
                self.p.disconnect(physicsClientId=self.client)
            except Exception:  # noqa: S110 - already gone (e.g. the server died); nothing to free
                pass
            self.client = None  # type: ignore[assignment]
        self._tmp.cleanup()

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = ["Scene"]
