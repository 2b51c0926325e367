"""Build a PyBullet (DIRECT) world from a :class:`SceneLayout`.

The layout is plain data (what goes where); this module is the only one that turns it into
PyBullet bodies: floor, a Franka Panda from ``pybullet_data``, the project's furniture URDFs,
``pybullet_data`` meshes where a household object has one (mug, duck) and labeled box or
cylinder proxies otherwise (pet, child, plant, dishes...). URDF text goes into a temporary
folder owned by the scene and removed by :meth:`Scene.close`.
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.errors import SimulationError
from regen.manipulation._pb import pybullet, pybullet_data_path
from regen.manipulation.urdf import AABB, RGBA, FurnitureSpec, Vec3, furniture, proxy_urdf

log = logging.getLogger(__name__)

DT = 1.0 / 240.0  # physics step [s]
PANDA_HOME = (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785)  # ready pose of the 7 arm joints [rad]
ARM_JOINTS = tuple(range(7))
FINGER_JOINTS = (9, 10)
EE_LINK = 11  # panda_grasptarget
FURNITURE_FRICTION = 4.0  # joint friction of furniture [N or N m]: doors stay where left


@dataclass
class FurniturePlacement:
    name: str  # entity name, e.g. 'door1'
    kind: str  # key of regen.manipulation.urdf.FURNITURE
    x: float  # [m] furniture frame origin in the world
    y: float  # [m]
    fraction: float = 0.0  # initial joint opening, 0 closed .. 1 open


@dataclass
class ObjectPlacement:
    name: str  # entity name, e.g. 'pet1'
    asset: str  # asset database id
    x: float  # [m] bottom centre
    y: float  # [m]
    z: float  # [m] height of the support it stands on
    size: Vec3  # length, width, height [m]
    dynamic: bool = False  # context objects are static; task items and riders are dynamic
    label: str = ""
    power: str | None = None  # a device's state ('on': its screen or bulb drawn lit)


@dataclass
class SceneLayout:
    furniture: list[FurniturePlacement] = field(default_factory=list)
    objects: list[ObjectPlacement] = field(default_factory=list)
    robot_xy: tuple[float, float] = (0.0, 0.0)  # [m]


@dataclass
class Body:
    name: str
    id: int
    kind: str  # 'robot', 'furniture', 'object'
    asset: str
    spec: FurnitureSpec | None = None
    joint: int | None = None  # index of the moving joint
    handle_link: int = -1  # link index carrying the handle (-1 = base)
    cavity_link: int | None = None
    origin: Vec3 = (0.0, 0.0, 0.0)  # where the furniture frame sits [m]
    size: Vec3 = (0.0, 0.0, 0.0)  # extents [m]
    cavity_closed_link_pos: Vec3 | None = None  # where the cavity link was when the cavity was measured
    power: str | None = None  # a context device's power state, as drawn


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


class Scene:
    """A live PyBullet world; use as a context manager so the client and temp files go away."""

    def __init__(self, layout: SceneLayout, *, use_meshes: bool = True):
        self.p = pybullet()
        self.layout = layout
        self._tmp = tempfile.TemporaryDirectory(prefix="regen-scene-")
        self.client = self.p.connect(self.p.DIRECT)
        self.bodies: dict[str, Body] = {}
        try:
            self._build(use_meshes)
        except Exception as exc:  # a broken URDF or asset must not leave a client behind
            self.close()
            if isinstance(exc, SimulationError):
                raise
            raise SimulationError(f"could not build the PyBullet scene: {exc}") from exc

    # --- building -----------------------------------------------------------------------------

    def _call(self, fn: str, *args: Any, **kw: Any) -> Any:
        return getattr(self.p, fn)(*args, physicsClientId=self.client, **kw)

    def _write(self, name: str, text: str) -> str:
        path = Path(self._tmp.name) / f"{name}.urdf"
        path.write_text(text, encoding="utf-8")
        return str(path)

    def _build(self, use_meshes: bool) -> None:
        data = pybullet_data_path()
        self._call("setAdditionalSearchPath", data)
        self._call("setGravity", 0, 0, -9.81)
        self._call("setTimeStep", DT)
        self.plane = self._call("loadURDF", "plane.urdf")
        rx, ry = self.layout.robot_xy
        robot = self._call("loadURDF", os.path.join(data, "franka_panda/panda.urdf"),
                           basePosition=[rx, ry, 0.0], useFixedBase=True)
        for j, q in zip(ARM_JOINTS, PANDA_HOME, strict=True):
            self._call("resetJointState", robot, j, q)
        for j in FINGER_JOINTS:
            self._call("resetJointState", robot, j, 0.04)
        self.bodies["robot"] = Body("robot", robot, "robot", "franka_panda", origin=(rx, ry, 0.0),
                                    size=(0.2, 0.2, 1.0))
        for f in self.layout.furniture:
            self._add_furniture(f)
        for o in self.layout.objects:
            self._add_object(o, use_meshes)

    def _add_furniture(self, f: FurniturePlacement) -> None:
        spec = furniture(f.kind)
        path = self._write(f.name, spec.urdf)
        bid = self._call("loadURDF", path, basePosition=[f.x, f.y, 0.0],
                         useFixedBase=not spec.dynamic)
        body = Body(f.name, bid, "furniture", f.kind, spec=spec, origin=(f.x, f.y, 0.0),
                    size=spec.footprint.size)
        names = {}
        for j in range(self._call("getNumJoints", bid)):
            info = self._call("getJointInfo", bid, j)
            names[info[1].decode()] = j
            names["link:" + info[12].decode()] = j
            # Joint friction through a zero-velocity motor: furniture stays where it is left.
            # slides get more: a bump of the forearm must not shut an open drawer
            friction = FURNITURE_FRICTION * (4 if info[2] == self.p.JOINT_PRISMATIC else 1)
            self._call("setJointMotorControl2", bid, j, self.p.VELOCITY_CONTROL, targetVelocity=0,
                       force=friction)
        if spec.joint is not None:
            body.joint = names[spec.joint]
            q0 = spec.closed + f.fraction * (spec.opened - spec.closed)
            self._call("resetJointState", bid, body.joint, q0)
        if spec.handle_link and spec.handle_link != "base":
            body.handle_link = names["link:" + spec.handle_link]
        if spec.cavity_link:
            body.cavity_link = names["link:" + spec.cavity_link]
            # the spec's cavity is given with the joint closed; remember where the link was then
            q = self._call("getJointState", bid, body.joint)[0]
            self._call("resetJointState", bid, body.joint, spec.closed)
            body.cavity_closed_link_pos = tuple(self._call("getLinkState", bid, body.cavity_link)[4])
            self._call("resetJointState", bid, body.joint, q)
        self.bodies[f.name] = body

    def _add_object(self, o: ObjectPlacement, use_meshes: bool) -> None:
        mass = 0.2 if o.dynamic else 0.0
        if use_meshes and o.asset in MESHES:
            file, rpy, scale = MESHES[o.asset]
            bid = self._call("loadURDF", file, basePosition=[o.x, o.y, o.z + 0.5],
                             baseOrientation=self._call("getQuaternionFromEuler", rpy),
                             globalScaling=scale, useFixedBase=not o.dynamic)
            lo, hi = self._call("getAABB", bid)
            pos, orn = self._call("getBasePositionAndOrientation", bid)
            centre = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2)
            new = (pos[0] + o.x - centre[0], pos[1] + o.y - centre[1], pos[2] + o.z - lo[2] + 0.001)
            self._call("resetBasePositionAndOrientation", bid, new, orn)
            lo, hi = self._call("getAABB", bid)
            size = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
            if mass:
                self._call("changeDynamics", bid, -1, mass=mass)
        else:
            rgba, shape = PROXY_STYLE.get(o.asset, ((0.6, 0.6, 0.6, 1), "box"))
            if o.power == "on":
                rgba = POWERED_ON.get(o.asset, rgba)
            path = self._write(o.name, proxy_urdf(o.name, o.size, rgba, shape=shape, mass=mass))
            bid = self._call("loadURDF", path, basePosition=[o.x, o.y, o.z + 0.001],
                             useFixedBase=not o.dynamic)
            size = o.size
        if o.dynamic:
            self._call("changeDynamics", bid, -1, lateralFriction=1.0)
        self.bodies[o.name] = Body(o.name, bid, "object", o.asset, origin=(o.x, o.y, o.z), size=size,
                                   power=o.power)

    # --- queries ------------------------------------------------------------------------------

    @property
    def robot(self) -> int:
        return self.bodies["robot"].id

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self._call("stepSimulation")

    def joint_position(self, name: str) -> float:
        b = self.bodies[name]
        if b.joint is None:
            return 0.0
        return float(self._call("getJointState", b.id, b.joint)[0])

    def joint_fraction(self, name: str) -> float:
        b = self.bodies[name]
        return b.spec.fraction(self.joint_position(name)) if b.spec and b.joint is not None else 0.0

    def link_pose(self, name: str, link: int) -> tuple[Vec3, tuple[float, float, float, float]]:
        b = self.bodies[name]
        if link < 0:
            pos, orn = self._call("getBasePositionAndOrientation", b.id)
        else:
            st = self._call("getLinkState", b.id, link, computeForwardKinematics=True)
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
        world, _ = self._call("multiplyTransforms", pos, orn, b.spec.handle_offset, (0, 0, 0, 1))
        return tuple(world)

    def position(self, name: str) -> Vec3:
        b = self.bodies[name]
        pos, _ = self._call("getBasePositionAndOrientation", b.id)
        return tuple(pos)

    def yaw(self, name: str) -> float:
        _, orn = self._call("getBasePositionAndOrientation", self.bodies[name].id)
        return float(self._call("getEulerFromQuaternion", orn)[2])

    def aabb(self, name: str, link: int | None = None) -> AABB:
        b = self.bodies[name]
        if link is None:
            lo, hi = self._call("getAABB", b.id, -1)
            for j in range(self._call("getNumJoints", b.id)):
                l2, h2 = self._call("getAABB", b.id, j)
                lo = [min(a, c) for a, c in zip(lo, l2, strict=True)]
                hi = [max(a, c) for a, c in zip(hi, h2, strict=True)]
        else:
            lo, hi = self._call("getAABB", b.id, link)
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
        return tuple(self._call("getLinkState", self.robot, EE_LINK, computeForwardKinematics=True)[4])

    def arm_state(self) -> list[float]:
        return [float(self._call("getJointState", self.robot, j)[0])
                for j in (*ARM_JOINTS, *FINGER_JOINTS)]

    def tilt(self, name: str) -> float:
        """Angle [rad] between the body's up axis and the world's (0: upright)."""
        _, orn = self._call("getBasePositionAndOrientation", self.bodies[name].id)
        m = self._call("getMatrixFromQuaternion", orn)
        return float(math.acos(max(-1.0, min(1.0, m[8]))))

    def contact(self, a: str, b: str) -> bool:
        return bool(self._call("getContactPoints", self.bodies[a].id, self.bodies[b].id))

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
