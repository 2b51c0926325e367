"""What a PyBullet scene holds, as plain data: the layout (what goes where), the bodies once
built, and the Franka Panda's joint numbering and ready pose.

The layout is written from a scenario (:func:`regen.manipulation.simulation.run.layout_from_scenario`)
or by hand; :mod:`regen.manipulation.simulation.build` turns it into PyBullet bodies.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from regen.manipulation.world.furniture import FurnitureSpec, Vec3

DT = 1.0 / 240.0  # physics step [s]
PANDA_HOME = (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785)  # ready pose of the 7 arm joints [rad]
ARM_JOINTS = tuple(range(7))
FINGER_JOINTS = (9, 10)
EE_LINK = 11  # panda_grasptarget


@dataclass
class FurniturePlacement:
    name: str  # entity name, e.g. 'door1'
    kind: str  # key of regen.manipulation.world.furniture.FURNITURE
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

    @property
    def is_robot(self) -> bool:
        return self.kind == "robot"
    power: str | None = None  # a context device's power state, as drawn


__all__ = ["ARM_JOINTS", "DT", "EE_LINK", "FINGER_JOINTS", "PANDA_HOME", "Body", "FurniturePlacement",
           "ObjectPlacement", "SceneLayout"]
