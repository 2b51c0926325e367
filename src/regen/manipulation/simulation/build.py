"""Load a :class:`~regen.manipulation.simulation.layout.SceneLayout` into a PyBullet client.

Floor, a Franka Panda from ``pybullet_data``, the project's furniture URDFs, ``pybullet_data``
meshes where a household object has one (mug, duck) and labeled box or cylinder proxies
otherwise (pet, child, plant, dishes...). URDF text goes into a folder the caller owns
(:class:`~regen.manipulation.simulation.scene.Scene` removes it when it closes).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from types import ModuleType
from typing import Any

from regen.manipulation.simulation.layout import (
    ARM_JOINTS,
    DT,
    FINGER_JOINTS,
    PANDA_HOME,
    Body,
    FurniturePlacement,
    ObjectPlacement,
    SceneLayout,
)
from regen.manipulation.simulation.pybullet import pybullet_data_path
from regen.manipulation.world.furniture import RGBA, Vec3, furniture, proxy_urdf

FURNITURE_FRICTION = 4.0  # joint friction of furniture [N or N m]: doors stay where left

# Colours and shapes of the proxies (things pybullet_data has no mesh for).
PROXY_STYLE: dict[str, tuple[RGBA, str]] = {
    "pet": ((0.55, 0.35, 0.2, 1), "box"), "child": ((0.95, 0.7, 0.6, 1), "cylinder"),
    "adult": ((0.3, 0.4, 0.75, 1), "cylinder"), "plant": ((0.2, 0.6, 0.25, 1), "cylinder"),
    "dishes": ((0.95, 0.95, 0.97, 1), "cylinder"), "book": ((0.7, 0.15, 0.15, 1), "box"),
    "laptop": ((0.3, 0.3, 0.33, 1), "box"), "bottle": ((0.15, 0.55, 0.3, 1), "cylinder"),
    "clothes": ((0.35, 0.5, 0.8, 1), "box"), "frozen_vegetables": ((0.6, 0.85, 0.95, 1), "box"),
    "trash_can": ((0.45, 0.45, 0.45, 1), "cylinder"), "tv": ((0.1, 0.1, 0.12, 1), "box"),
    "desk_lamp": ((0.55, 0.5, 0.35, 1), "cylinder"), "fruit": ((0.95, 0.55, 0.1, 1), "cylinder"),
    "toy": ((0.95, 0.3, 0.6, 1), "box"), "cup": ((0.9, 0.25, 0.2, 1), "cylinder"),
    "visitor": ((0.55, 0.3, 0.6, 1), "cylinder"), "spill": ((0.85, 0.55, 0.1, 0.9), "box"),
    "mop": ((0.85, 0.8, 0.6, 1), "cylinder"), "ingredients": ((0.9, 0.8, 0.5, 1), "box"),
}
#: a device that is on is drawn lit (a bright screen, a glowing bulb); off, in PROXY_STYLE's colour
POWERED_ON: dict[str, RGBA] = {
    "tv": (0.35, 0.7, 1.0, 1), "laptop": (0.55, 0.8, 1.0, 1), "desk_lamp": (1.0, 1.0, 0.65, 1),
}

# pybullet_data meshes: file, orientation (roll, pitch, yaw) [rad], global scale.
MESHES: dict[str, tuple[str, Vec3, float]] = {
    "cup": ("objects/mug.urdf", (0.0, 0.0, 0.0), 1.0),
    "toy": ("duck_vhacd.urdf", (math.pi / 2, 0.0, 0.0), 1.0),
}


class SceneBuilder:
    """Loads bodies into one PyBullet client, writing URDF text into ``folder``."""

    def __init__(self, p: ModuleType, client: int, folder: Path) -> None:
        self.p = p
        self.client = client
        self.folder = folder

    def call(self, fn: str, *args: Any, **kw: Any) -> Any:
        return getattr(self.p, fn)(*args, physicsClientId=self.client, **kw)

    def write(self, name: str, text: str) -> str:
        path = self.folder / f"{name}.urdf"
        path.write_text(text, encoding="utf-8")
        return str(path)

    def build(self, layout: SceneLayout, use_meshes: bool, bodies: dict[str, Body]) -> int:
        """Floor, robot, furniture and objects into ``bodies`` (by name); returns the floor's id."""
        data = pybullet_data_path()
        self.call("setAdditionalSearchPath", data)
        self.call("setGravity", 0, 0, -9.81)
        self.call("setTimeStep", DT)
        plane = self.call("loadURDF", "plane.urdf")
        bodies["robot"] = self.add_robot(data, layout.robot_xy)
        for f in layout.furniture:
            bodies[f.name] = self.add_furniture(f)
        for o in layout.objects:
            bodies[o.name] = self.add_object(o, use_meshes)
        return plane

    def add_robot(self, data: str, xy: tuple[float, float]) -> Body:
        """The Franka Panda on a fixed base at ``xy`` [m], in its ready pose, hand open."""
        rx, ry = xy
        robot = self.call("loadURDF", os.path.join(data, "franka_panda/panda.urdf"),
                          basePosition=[rx, ry, 0.0], useFixedBase=True)
        for j, q in zip(ARM_JOINTS, PANDA_HOME, strict=True):
            self.call("resetJointState", robot, j, q)
        for j in FINGER_JOINTS:
            self.call("resetJointState", robot, j, 0.04)
        return Body("robot", robot, "robot", "franka_panda", origin=(rx, ry, 0.0), size=(0.2, 0.2, 1.0))

    def add_furniture(self, f: FurniturePlacement) -> Body:
        spec = furniture(f.kind)
        path = self.write(f.name, spec.urdf)
        bid = self.call("loadURDF", path, basePosition=[f.x, f.y, 0.0], useFixedBase=not spec.dynamic)
        body = Body(f.name, bid, "furniture", f.kind, spec=spec, origin=(f.x, f.y, 0.0),
                    size=spec.footprint.size)
        names = {}
        for j in range(self.call("getNumJoints", bid)):
            info = self.call("getJointInfo", bid, j)
            names[info[1].decode()] = j
            names["link:" + info[12].decode()] = j
            # Joint friction through a zero-velocity motor: furniture stays where it is left.
            # slides get more: a bump of the forearm must not shut an open drawer
            friction = FURNITURE_FRICTION * (4 if info[2] == self.p.JOINT_PRISMATIC else 1)
            self.call("setJointMotorControl2", bid, j, self.p.VELOCITY_CONTROL, targetVelocity=0,
                      force=friction)
        if spec.joint is not None:
            body.joint = names[spec.joint]
            q0 = spec.closed + f.fraction * (spec.opened - spec.closed)
            self.call("resetJointState", bid, body.joint, q0)
        if spec.handle_link and spec.handle_link != "base":
            body.handle_link = names["link:" + spec.handle_link]
        if spec.cavity_link:
            body.cavity_link = names["link:" + spec.cavity_link]
            # the spec's cavity is given with the joint closed; remember where the link was then
            q = self.call("getJointState", bid, body.joint)[0]
            self.call("resetJointState", bid, body.joint, spec.closed)
            body.cavity_closed_link_pos = tuple(self.call("getLinkState", bid, body.cavity_link)[4])
            self.call("resetJointState", bid, body.joint, q)
        return body

    def add_object(self, o: ObjectPlacement, use_meshes: bool) -> Body:
        mass = 0.2 if o.dynamic else 0.0
        if use_meshes and o.asset in MESHES:
            file, rpy, scale = MESHES[o.asset]
            bid = self.call("loadURDF", file, basePosition=[o.x, o.y, o.z + 0.5],
                            baseOrientation=self.call("getQuaternionFromEuler", rpy),
                            globalScaling=scale, useFixedBase=not o.dynamic)
            lo, hi = self.call("getAABB", bid)
            pos, orn = self.call("getBasePositionAndOrientation", bid)
            centre = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2)
            new = (pos[0] + o.x - centre[0], pos[1] + o.y - centre[1], pos[2] + o.z - lo[2] + 0.001)
            self.call("resetBasePositionAndOrientation", bid, new, orn)
            lo, hi = self.call("getAABB", bid)
            size = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
            if mass:
                self.call("changeDynamics", bid, -1, mass=mass)
        else:
            rgba, shape = PROXY_STYLE.get(o.asset, ((0.6, 0.6, 0.6, 1), "box"))
            if o.power == "on":
                rgba = POWERED_ON.get(o.asset, rgba)
            path = self.write(o.name, proxy_urdf(o.name, o.size, rgba, shape=shape, mass=mass))
            bid = self.call("loadURDF", path, basePosition=[o.x, o.y, o.z + 0.001],
                            useFixedBase=not o.dynamic)
            size = o.size
        if o.dynamic:
            self.call("changeDynamics", bid, -1, lateralFriction=1.0)
        return Body(o.name, bid, "object", o.asset, origin=(o.x, o.y, o.z), size=size, power=o.power)


__all__ = ["FURNITURE_FRICTION", "MESHES", "POWERED_ON", "PROXY_STYLE", "SceneBuilder"]
