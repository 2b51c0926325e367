"""Project-generated URDFs for articulated household furniture (and simple proxies).

Each generator returns a :class:`FurnitureSpec`: the URDF text plus the facts the rest of the
package needs (which joint moves, where the handle is, which box inside can host objects, where
the top surface is). URDF text is written into a per-scene temporary folder by
:mod:`regen.manipulation.simulation.scene`, never into the package.

Frame convention (all furniture): origin on the floor under the footprint centre, the front
face looks along -x (towards a robot standing at smaller x), z up. Sizes are household objects
scaled so that a floor-mounted Franka Panda reaches their handles, as RoboGen scales its
PartNet-Mobility assets.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]

WOOD: RGBA = (0.62, 0.45, 0.28, 1.0)
WHITE: RGBA = (0.92, 0.92, 0.9, 1.0)
GREY: RGBA = (0.55, 0.57, 0.6, 1.0)
DARK: RGBA = (0.2, 0.2, 0.22, 1.0)
METAL: RGBA = (0.75, 0.75, 0.78, 1.0)
WALL: RGBA = (0.85, 0.82, 0.74, 1.0)
GLASS: RGBA = (0.6, 0.8, 0.95, 0.8)
RED: RGBA = (0.8, 0.15, 0.1, 1.0)


@dataclass(frozen=True)
class Box:
    size: Vec3  # full extents [m]
    xyz: Vec3  # centre in the link frame [m]
    rgba: RGBA = GREY
    collide: bool = True


@dataclass(frozen=True)
class Cyl:
    radius: float  # [m]
    length: float  # [m], along the link's z unless rpy says otherwise
    xyz: Vec3
    rgba: RGBA = GREY
    rpy: Vec3 = (0.0, 0.0, 0.0)  # [rad]
    collide: bool = True


Shape = Box | Cyl


@dataclass(frozen=True)
class AABB:
    """Axis-aligned box in the furniture frame (or world frame once placed) [m]."""

    lo: Vec3
    hi: Vec3

    @property
    def size(self) -> Vec3:
        return (self.hi[0] - self.lo[0], self.hi[1] - self.lo[1], self.hi[2] - self.lo[2])


@dataclass
class FurnitureSpec:
    kind: str  # door, window, drawer, cabinet, faucet, oven, fridge, open_box, bucket, lamp, display, table
    urdf: str
    footprint: AABB  # whole base in the furniture frame [m]
    joint: str | None = None  # name of the moving joint, if any
    closed: float = 0.0  # joint value when closed / off [rad or m]
    opened: float = 0.0  # joint value when fully open / on [rad or m]
    handle_link: str | None = None  # link carrying the handle
    handle_offset: Vec3 = (0.0, 0.0, 0.0)  # handle point in the handle link frame [m]
    approach: str = "front"  # gripper approach at the handle: 'front' (along +x) or 'top' (down)
    cavity: AABB | None = None  # interior that can host objects, furniture frame [m]
    cavity_link: str | None = None  # None: the cavity is in the base (static); else it moves
    top: float | None = None  # height of a top surface that can support objects [m]
    under: float | None = None  # free height under it (tables) [m]
    wall: bool = False  # has a wall with an opening: 'outside' is defined
    sweep: AABB | None = None  # floor area the moving part sweeps, furniture frame [m]
    dynamic: bool = False  # a free body the robot can carry (bucket)
    notes: dict[str, str] = field(default_factory=dict)

    def fraction(self, q: float) -> float:
        """Joint value as a fraction from closed (0) to open (1)."""
        span = self.opened - self.closed
        return 0.0 if span == 0 else (q - self.closed) / span


# --- URDF text -------------------------------------------------------------------------------


def _f(v: float) -> str:
    return f"{v:.4f}".rstrip("0").rstrip(".") if v else "0"


def _v(vec: Vec3) -> str:
    return " ".join(_f(x) for x in vec)


def _geometry(s: Shape) -> str:
    if isinstance(s, Box):
        return f'<box size="{_v(s.size)}"/>'
    return f'<cylinder radius="{_f(s.radius)}" length="{_f(s.length)}"/>'


def _origin(s: Shape) -> str:
    rpy = s.rpy if isinstance(s, Cyl) else (0.0, 0.0, 0.0)
    return f'<origin xyz="{_v(s.xyz)}" rpy="{_v(rpy)}"/>'


def _link(name: str, shapes: list[Shape], mass: float) -> str:
    # each visual gets its own material name: PyBullet shares colours between equal names
    parts = [f"<link name={quoteattr(name)}>",
             f'<inertial><origin xyz="0 0 0"/><mass value="{_f(mass)}"/>'
             '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>']
    for i, s in enumerate(shapes):
        parts.append(f"<visual>{_origin(s)}<geometry>{_geometry(s)}</geometry>"
                     f'<material name="{name}_m{i}"><color rgba="{" ".join(_f(c) for c in s.rgba)}"/>'
                     "</material></visual>")
        if s.collide:
            parts.append(f"<collision>{_origin(s)}<geometry>{_geometry(s)}</geometry></collision>")
    parts.append("</link>")
    return "".join(parts)


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # revolute, prismatic, fixed
    parent: str
    child: str
    xyz: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    lower: float = 0.0
    upper: float = 0.0


def _joint(j: Joint) -> str:
    limit = (f'<limit lower="{_f(j.lower)}" upper="{_f(j.upper)}" effort="50" velocity="2"/>'
             '<dynamics damping="0.5" friction="0.0"/>' if j.kind != "fixed" else "")
    return (f"<joint name={quoteattr(j.name)} type={quoteattr(j.kind)}>"
            f"<parent link={quoteattr(j.parent)}/><child link={quoteattr(j.child)}/>"
            f'<origin xyz="{_v(j.xyz)}" rpy="0 0 0"/><axis xyz="{_v(j.axis)}"/>{limit}</joint>')


def build_urdf(name: str, links: dict[str, tuple[list[Shape], float]], joints: list[Joint]) -> str:
    """URDF text for a tree of links (name -> (shapes, mass [kg])) joined by ``joints``."""
    body = "".join(_link(n, shapes, m) for n, (shapes, m) in links.items())
    return (f'<?xml version="1.0"?><robot name={quoteattr(name)}>{body}'
            + "".join(_joint(j) for j in joints) + "</robot>")


def hollow_box(size: Vec3, t: float, rgba: RGBA, *, open_front: bool, open_top: bool = False,
               z0: float = 0.0) -> list[Shape]:
    """Walls of a box (depth x, width y, height z) standing on z0, optionally open at the
    front (-x) or the top, wall thickness ``t`` [m]."""
    d, w, h = size
    out: list[Shape] = [
        Box((d, w, t), (0, 0, z0 + t / 2), rgba),  # bottom
        Box((t, w, h), (d / 2 - t / 2, 0, z0 + h / 2), rgba),  # back
        Box((d, t, h), (0, -w / 2 + t / 2, z0 + h / 2), rgba),  # right
        Box((d, t, h), (0, w / 2 - t / 2, z0 + h / 2), rgba),  # left
    ]
    if not open_top:
        out.append(Box((d, w, t), (0, 0, z0 + h - t / 2), rgba))
    if not open_front:
        out.append(Box((t, w, h), (-d / 2 + t / 2, 0, z0 + h / 2), rgba))
    return out


# --- furniture -------------------------------------------------------------------------------


def door() -> FurnitureSpec:
    """A wall with a hinged door that opens towards the robot (+rotation about z)."""
    gap, hgt, wall_w, wall_h, t = 0.55, 1.3, 2.4, 1.5, 0.06
    side = (wall_w - gap) / 2
    wall = [Box((t, side, wall_h), (0, gap / 2 + side / 2, wall_h / 2), WALL),
            Box((t, side, wall_h), (0, -gap / 2 - side / 2, wall_h / 2), WALL),
            Box((t, gap, wall_h - hgt), (0, 0, hgt + (wall_h - hgt) / 2), WALL)]
    panel_w = gap - 0.02
    panel = [Box((0.04, panel_w, hgt - 0.02), (0, panel_w / 2, (hgt - 0.02) / 2 + 0.01), WOOD),
             Box((0.07, 0.03, 0.03), (-0.055, panel_w - 0.06, 0.8), METAL)]
    urdf = build_urdf("door", {"base": (wall, 0.0), "panel": (panel, 2.0)},
                      [Joint("hinge", "revolute", "base", "panel", (0, -gap / 2 + 0.01, 0),
                             (0, 0, 1), 0.0, 1.6)])
    return FurnitureSpec("door", urdf, AABB((-t / 2, -wall_w / 2, 0), (t / 2, wall_w / 2, wall_h)),
                         joint="hinge", closed=0.0, opened=1.6, handle_link="panel",
                         handle_offset=(-0.085, panel_w - 0.06, 0.8), wall=True,
                         sweep=AABB((-panel_w - 0.05, -gap / 2, 0), (0, gap / 2, hgt)))


def window() -> FurnitureSpec:
    """A wall with a casement window (hinged on a vertical axis, opens towards the robot)."""
    gap, sill, top, wall_w, wall_h, t = 0.5, 0.5, 0.95, 2.4, 1.5, 0.06
    side = (wall_w - gap) / 2
    wall = [Box((t, side, wall_h), (0, gap / 2 + side / 2, wall_h / 2), WALL),
            Box((t, side, wall_h), (0, -gap / 2 - side / 2, wall_h / 2), WALL),
            Box((t, gap, sill), (0, 0, sill / 2), WALL),
            Box((t, gap, wall_h - top), (0, 0, top + (wall_h - top) / 2), WALL)]
    pw, ph = gap - 0.02, top - sill - 0.02
    panel = [Box((0.03, pw, ph), (0, pw / 2, sill + 0.01 + ph / 2), GLASS),
             Box((0.06, 0.025, 0.025), (-0.045, pw - 0.05, sill + 0.01 + ph / 2), METAL)]
    urdf = build_urdf("window", {"base": (wall, 0.0), "sash": (panel, 1.0)},
                      [Joint("hinge", "revolute", "base", "sash", (0, -gap / 2 + 0.01, 0),
                             (0, 0, 1), 0.0, 1.3)])
    return FurnitureSpec("window", urdf, AABB((-t / 2, -wall_w / 2, 0), (t / 2, wall_w / 2, wall_h)),
                         joint="hinge", closed=0.0, opened=1.3, handle_link="sash",
                         handle_offset=(-0.07, pw - 0.05, sill + 0.01 + ph / 2), wall=True,
                         sweep=AABB((-pw - 0.05, -gap / 2, sill), (0, gap / 2, top)))


def drawer() -> FurnitureSpec:
    """A chest with one drawer that slides out towards the robot (prismatic along -x)."""
    d, w, h, t = 0.45, 0.5, 0.42, 0.02
    chest = hollow_box((d, w, h), t, WOOD, open_front=True)
    dd, dw, dh = d - 2 * t - 0.01, w - 2 * t - 0.01, 0.16
    box = hollow_box((dd, dw, dh), 0.012, WHITE, open_front=True, open_top=True, z0=0.0)
    box.append(Box((0.02, w - 0.01, dh + 0.06), (-dd / 2 - 0.01, 0, (dh + 0.06) / 2), WOOD))
    box.append(Box((0.05, 0.12, 0.025), (-dd / 2 - 0.045, 0, 0.12), METAL))
    urdf = build_urdf("drawer", {"base": (chest, 0.0), "drawer": (box, 1.0)},
                      [Joint("slide", "prismatic", "base", "drawer", (0.0, 0, t + 0.12),
                             (-1, 0, 0), 0.0, 0.3)])
    return FurnitureSpec("drawer", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)),
                         joint="slide", closed=0.0, opened=0.3, handle_link="drawer",
                         handle_offset=(-dd / 2 - 0.07, 0, 0.12),
                         cavity=AABB((-dd / 2 + 0.015, -dw / 2 + 0.015, t + 0.132),
                                     (dd / 2 - 0.015, dw / 2 - 0.015, t + 0.12 + dh)),
                         cavity_link="drawer", top=h,
                         sweep=AABB((-d / 2 - 0.35, -w / 2, 0), (-d / 2, w / 2, h)))


def cabinet(*, hinge_sign: float = 1.0) -> FurnitureSpec:
    """A cabinet with one hinged door (vertical hinge on the right, opens towards the robot)."""
    d, w, h, t = 0.4, 0.5, 0.6, 0.02
    body = hollow_box((d, w, h), t, WOOD, open_front=True)
    body.append(Box((d - 2 * t, w - 2 * t, t), (0, 0, h / 2), WOOD))  # shelf
    pw = w - 0.01
    door_shapes: list[Shape] = [Box((0.02, pw, h - 0.01), (0, pw / 2, h / 2), WHITE),
                                Box((0.06, 0.025, 0.12), (-0.04, pw - 0.05, h * 0.6), METAL)]
    urdf = build_urdf("cabinet", {"base": (body, 0.0), "door": (door_shapes, 1.0)},
                      [Joint("hinge", "revolute", "base", "door", (-d / 2 - 0.011, -w / 2, 0),
                             (0, 0, 1), 0.0, 1.7)])
    return FurnitureSpec("cabinet", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)),
                         joint="hinge", closed=0.0, opened=1.7, handle_link="door",
                         handle_offset=(-0.07, pw - 0.05, h * 0.6),
                         cavity=AABB((-d / 2 + t, -w / 2 + t, h / 2 + t / 2),
                                     (d / 2 - t, w / 2 - t, h - t)),
                         top=h, sweep=AABB((-d / 2 - pw - 0.02, -w / 2, 0), (-d / 2, w / 2, h)))


def faucet() -> FurnitureSpec:
    """A sink counter with a basin and a faucet whose lever turns about z (water flow)."""
    d, w, h = 0.45, 0.6, 0.45
    bw, bd, bdep = 0.3, 0.25, 0.12  # basin width (y), depth (x), depth down [m]
    bx = -0.03  # basin centre x
    counter: list[Shape] = [
        Box((d, w, h - bdep), (0, 0, (h - bdep) / 2), WHITE),
        Box((d, (w - bw) / 2, bdep), (0, bw / 2 + (w - bw) / 4, h - bdep / 2), WHITE),
        Box((d, (w - bw) / 2, bdep), (0, -bw / 2 - (w - bw) / 4, h - bdep / 2), WHITE),
        Box((bx - bd / 2 + d / 2, bw, bdep), ((-d / 2 + bx - bd / 2) / 2, 0, h - bdep / 2), WHITE),
        Box((d / 2 - bx - bd / 2, bw, bdep), ((d / 2 + bx + bd / 2) / 2, 0, h - bdep / 2), WHITE),
        Cyl(0.018, 0.22, (0.17, 0, h + 0.11), METAL),
        Box((0.14, 0.03, 0.03), (0.11, 0, h + 0.21), METAL, collide=False),
    ]
    lever: list[Shape] = [Cyl(0.02, 0.04, (0, 0, 0.02), METAL),
                          Box((0.12, 0.02, 0.02), (-0.06, 0, 0.045), RED)]
    urdf = build_urdf("faucet", {"base": (counter, 0.0), "lever": (lever, 0.2)},
                      [Joint("lever_joint", "revolute", "base", "lever", (0.12, 0.12, h),
                             (0, 0, 1), 0.0, 1.2)])
    return FurnitureSpec("faucet", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h + 0.22)),
                         joint="lever_joint", closed=0.0, opened=1.2, handle_link="lever",
                         handle_offset=(-0.11, 0, 0.045), approach="top",
                         cavity=AABB((bx - bd / 2, -bw / 2, h - bdep), (bx + bd / 2, bw / 2, h)),
                         top=h, notes={"state": "water flow"})


def oven() -> FurnitureSpec:
    """An oven with a rotary knob on the front; the knob has a fin to turn it by."""
    d, w, h = 0.5, 0.55, 0.5
    body: list[Shape] = [Box((d, w, h), (0, 0, h / 2), GREY),
                         Box((0.01, 0.4, 0.25), (-d / 2 - 0.004, 0.0, 0.2), DARK, collide=False)]
    knob: list[Shape] = [Cyl(0.03, 0.03, (-0.015, 0, 0), DARK, rpy=(0, 1.5708, 0)),
                         Box((0.03, 0.012, 0.05), (-0.04, 0, 0.03), RED)]
    urdf = build_urdf("oven", {"base": (body, 0.0), "knob": (knob, 0.1)},
                      [Joint("knob_joint", "revolute", "base", "knob", (-d / 2, -0.15, 0.43),
                             (-1, 0, 0), 0.0, 1.5)])
    return FurnitureSpec("oven", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)),
                         joint="knob_joint", closed=0.0, opened=1.5, handle_link="knob",
                         handle_offset=(-0.05, 0, 0.045), top=h, notes={"state": "heat"})


def fridge() -> FurnitureSpec:
    """A small fridge with a hinged door and one shelf."""
    d, w, h, t = 0.45, 0.5, 0.9, 0.03
    body = hollow_box((d, w, h), t, WHITE, open_front=True)
    body.append(Box((d - 2 * t, w - 2 * t, 0.02), (0, 0, 0.42), WHITE))  # shelf
    pw = w - 0.01
    door_shapes: list[Shape] = [Box((0.03, pw, h - 0.01), (0, pw / 2, h / 2), WHITE),
                                Box((0.05, 0.025, 0.25), (-0.04, pw - 0.05, 0.55), METAL)]
    urdf = build_urdf("fridge", {"base": (body, 0.0), "door": (door_shapes, 2.0)},
                      [Joint("hinge", "revolute", "base", "door", (-d / 2 - 0.016, -w / 2, 0),
                             (0, 0, 1), 0.0, 1.9)])
    return FurnitureSpec("fridge", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)),
                         joint="hinge", closed=0.0, opened=1.9, handle_link="door",
                         handle_offset=(-0.065, pw - 0.05, 0.55),
                         cavity=AABB((-d / 2 + t, -w / 2 + t, 0.43), (d / 2 - t, w / 2 - t, h - t)),
                         top=h, sweep=AABB((-d / 2 - pw, -w / 2, 0), (-d / 2, w / 2, h)))


def open_box() -> FurnitureSpec:
    """An open storage box (no joint)."""
    d, w, h = 0.3, 0.36, 0.16
    urdf = build_urdf("open_box", {"base": (hollow_box((d, w, h), 0.015, WOOD, open_front=False,
                                                        open_top=True), 0.0)}, [])
    return FurnitureSpec("open_box", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)),
                         cavity=AABB((-d / 2 + 0.015, -w / 2 + 0.015, 0.015),
                                     (d / 2 - 0.015, w / 2 - 0.015, h)))


def bucket() -> FurnitureSpec:
    """A bucket with a handle bar: one free body the robot lifts by the bar."""
    d, h = 0.22, 0.2
    shapes = hollow_box((d, d, h), 0.012, (0.2, 0.45, 0.8, 1.0), open_front=False, open_top=True)
    shapes += [Box((0.012, 0.012, 0.1), (0, d / 2 - 0.006, h + 0.05), METAL),
               Box((0.012, 0.012, 0.1), (0, -d / 2 + 0.006, h + 0.05), METAL),
               Box((0.02, d, 0.015), (0, 0, h + 0.1), METAL)]
    urdf = build_urdf("bucket", {"base": (shapes, 0.6)}, [])
    return FurnitureSpec("bucket", urdf, AABB((-d / 2, -d / 2, 0), (d / 2, d / 2, h + 0.11)),
                         handle_link="base", handle_offset=(0, 0, h + 0.1), approach="top",
                         dynamic=True)


def lamp() -> FurnitureSpec:
    """A floor lamp with a push switch on its base (prismatic, pressed down = on)."""
    r, h = 0.15, 0.45
    base: list[Shape] = [Cyl(r, 0.04, (0, 0, 0.02), DARK), Cyl(0.012, h, (0, 0, 0.04 + h / 2), METAL),
                         Cyl(0.09, 0.12, (0, 0, 0.04 + h + 0.04), WHITE, collide=False)]
    button: list[Shape] = [Cyl(0.022, 0.03, (0, 0, 0.015), RED)]
    urdf = build_urdf("lamp", {"base": (base, 0.0), "switch": (button, 0.05)},
                      [Joint("switch_joint", "prismatic", "base", "switch", (-0.11, 0, 0.035),
                             (0, 0, -1), 0.0, 0.015)])
    return FurnitureSpec("lamp", urdf, AABB((-r, -r, 0), (r, r, 0.04 + h + 0.1)),
                         joint="switch_joint", closed=0.0, opened=0.015, handle_link="switch",
                         handle_offset=(0, 0, 0.03), approach="top", notes={"state": "power"})


def display() -> FurnitureSpec:
    """A monitor on a stand whose screen tilts about the horizontal y axis."""
    base: list[Shape] = [Box((0.2, 0.25, 0.02), (0, 0, 0.01), DARK),
                         Box((0.03, 0.05, 0.45), (0.03, 0, 0.245), DARK)]
    screen: list[Shape] = [Box((0.03, 0.5, 0.3), (0, 0, 0.0), DARK),
                           Box((0.005, 0.46, 0.26), (-0.017, 0, 0), (0.2, 0.3, 0.5, 1.0),
                               collide=False)]
    urdf = build_urdf("display", {"base": (base, 0.0), "screen": (screen, 0.5)},
                      [Joint("tilt", "revolute", "base", "screen", (0.0, 0, 0.5), (0, 1, 0),
                             -0.2, 0.6)])
    return FurnitureSpec("display", urdf, AABB((-0.1, -0.25, 0), (0.1, 0.25, 0.65)),
                         joint="tilt", closed=0.0, opened=0.6, handle_link="screen",
                         handle_offset=(-0.02, 0.0, 0.15), top=None)


def table() -> FurnitureSpec:
    """A plain table: a top surface and free room underneath."""
    d, w, h, t = 0.5, 0.9, 0.55, 0.04
    legs = [Box((0.04, 0.04, h - t), (sx * (d / 2 - 0.03), sy * (w / 2 - 0.03), (h - t) / 2), WOOD)
            for sx in (-1, 1) for sy in (-1, 1)]
    urdf = build_urdf("table", {"base": ([Box((d, w, t), (0, 0, h - t / 2), WOOD), *legs], 0.0)}, [])
    return FurnitureSpec("table", urdf, AABB((-d / 2, -w / 2, 0), (d / 2, w / 2, h)), top=h,
                         under=h - t)


FURNITURE = {
    "door": door, "window": window, "drawer": drawer, "cabinet": cabinet, "faucet": faucet,
    "oven": oven, "fridge": fridge, "open_box": open_box, "bucket": bucket, "lamp": lamp,
    "display": display, "table": table,
}


def furniture(kind: str) -> FurnitureSpec:
    """The spec of a furniture kind (see :data:`FURNITURE`)."""
    try:
        return FURNITURE[kind]()
    except KeyError:
        raise KeyError(f"unknown furniture {kind!r}; known: {sorted(FURNITURE)}") from None


def proxy_urdf(name: str, size: Vec3, rgba: RGBA, *, shape: str = "box", mass: float = 0.0) -> str:
    """A labeled proxy body (box or upright cylinder) for things with no mesh (pet, child...).
    Origin at the bottom centre so placing it at z = support height sets it down."""
    length, width, height = size
    geom: Shape
    if shape == "cylinder":
        geom = Cyl(min(length, width) / 2, height, (0, 0, height / 2), rgba)
    else:
        geom = Box(size, (0, 0, height / 2), rgba)
    return build_urdf(name, {"base": ([geom], mass)}, [])
