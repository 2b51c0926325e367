"""The forward camera of a driving run: what the ego's driver sees, rendered by Panda3D.

The bird's-eye map (:mod:`.roads`) is triangulated flat on the ground and painted bottom first in
its order and colours; the bird's-eye actors (:mod:`.actors`) are shaded boxes per asset whose
visible states are lamps and panels recoloured or shown per frame. Panda3D runs headless on the
CPU through its software display (``p3tinydisplay``: fixed function, vertex colours, no shaders,
lights or model files): frames are byte-identical. One engine serves the process (docs/camera.md).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
from PIL import Image

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.driving.render import actors as bev
from regen.driving.render import roads
from regen.errors import ConfigError, DependencyNotInstalled, RegenError

__all__ = ["EYE_AHEAD", "EYE_HEIGHT", "HFOV", "CameraNotInstalled", "camera_available", "camera_frames"]

SIZE = (640, 360)  # default frame (width, height) [px]
HFOV = 90.0  # horizontal field of view [deg]; the vertical one follows from the frame's aspect
EYE_HEIGHT = 1.2  # camera above the road [m]
EYE_AHEAD = 1 / 6  # camera ahead of the ego's centre [fraction of its length]: its front third
NEAR, FAR = 0.5, 400.0  # clip planes [m]
GROUND_MARGIN = 600.0  # the flat ground reaches this far beyond the map and the actors [m]
MARK_W = 0.15  # lane line width [m]; the yellow centre line is 1.5 times as wide, as in bird's eye
DASH, GAP = 3.0, 6.0  # dashed lane lines [m], as in bird's eye

# Colors (RGB) the bird's-eye pictures do not have, and lamps that are off.
SKY, GROUND, GLASS, TYRE = (150, 190, 232), (128, 146, 108), (40, 50, 64), (24, 24, 26)
SKIN, TROUSERS, HEADLAMP = (224, 172, 140), (52, 58, 84), (236, 236, 214)
POLE, HOUSING, CONE, WHITE, BARRIER = (70, 72, 76), (28, 28, 30), (255, 110, 20), (240, 240, 240), (200, 40, 30)
BRAKE_OFF, HAZARD_OFF, SIREN_OFF, LAMP_OFF = (90, 14, 14), (100, 74, 20), (110, 110, 116), (44, 44, 44)
JACKETS = {"police_officer": (30, 40, 110), "road_worker": (250, 200, 0)}
_AREAS = (("sidewalks", roads.SIDEWALK), ("shoulders", roads.SHOULDER), ("roads", roads.ROAD),
          ("intersections", roads.JUNCTION), ("crossings", roads.CROSSING))  # painted bottom first
_SHADES = (0.92, 0.70, 0.82, 0.78, 1.00, 0.45)  # front, rear, left, right, top, bottom faces
# Corners of a box face, as bits (x, y, z) of its 8 corners, in _SHADES order.
_FACES = ((1, 3, 7, 5), (0, 4, 6, 2), (2, 6, 7, 3), (0, 1, 5, 4), (4, 5, 7, 6), (0, 2, 3, 1))
_PRC = ("load-display p3tinydisplay\nwindow-type offscreen\naudio-library-name null\n"
        "sync-video false\nframebuffer-multisample 0\n")


class CameraNotInstalled(DependencyNotInstalled, ImportError):
    """Panda3D, which the forward camera renders with, is not installed."""

    def __init__(self):
        super().__init__("panda3d", "camera", "the forward camera")
        # ImportError prints its ``msg``; both it and ``args`` carry the whole message
        self.msg = str(self.args[0])
        self.args = (self.msg,)


def camera_available() -> bool:
    """True when Panda3D can be imported, so :func:`camera_frames` can render."""
    try:
        import panda3d.core  # noqa: F401
    except ImportError:
        return False
    return True


def camera_frames(scenario: Scenario, trace: Trace, times: Sequence[float], *,
                  size: tuple[int, int] = SIZE, map_path: Path | None = None) -> list[Image.Image]:
    """The ego's forward view at each of ``times`` [s] (the nearest step of the trace), as RGB
    images of ``size`` (width, height) [px].

    The camera sits :data:`EYE_HEIGHT` [m] above the road and :data:`EYE_AHEAD` of the ego's
    length ahead of its centre, on its axis, looking level along its heading, with a horizontal
    field of view of :data:`HFOV` [deg]; the ego itself is not drawn. The map is ``map_path``
    when given, else the one the trace names; one that cannot be read is drawn as plain ground,
    with a warning. Raises :class:`CameraNotInstalled` (an ImportError) without Panda3D and
    :class:`ConfigError` for a trace without steps or without an ego.
    """
    width, height = int(size[0]), int(size[1])
    if width <= 0 or height <= 0:
        raise ConfigError(f"camera frame size must be positive, got {size!r}")
    renderer = _renderer()
    if trace.steps == 0:
        raise ConfigError(f"camera of scenario {scenario.id!r}: the trace has no steps")
    layers = roads.read_map_layers(Path(map_path)) if map_path is not None else roads.map_layers(scenario, trace)
    renderer.build(trace, layers)
    stamps = np.asarray(trace.times, float)
    steps = [int(np.argmin(np.abs(stamps - float(t)))) for t in times]  # the earlier on a tie
    return [renderer.draw(i, float(stamps[i]), (width, height)) for i in steps]


class _Mesh:
    """Triangles with one color per vertex, in an actor's frame [m] (x ahead, y left, z up)."""

    def __init__(self) -> None:
        self.points: list[np.ndarray] = []  # (k, 3) per batch, three rows a triangle
        self.colors: list[np.ndarray] = []  # (k, 3) uint8

    def add(self, points: np.ndarray, rgb) -> None:
        self.points.append(np.asarray(points, np.float32).reshape(-1, 3))
        self.colors.append(np.broadcast_to(np.asarray(rgb, np.uint8).reshape(-1, 3), self.points[-1].shape))

    def box(self, x0, x1, y0, y1, z0, z1, rgb, yaw: float = 0.0, pivot=(0.0, 0.0)) -> None:
        """A box (bounds in any order), turned ``yaw`` [rad] about ``pivot`` (x, y), each face
        shaded by a fixed amount so its shape reads without lights."""
        (x0, x1), (y0, y1), (z0, z1) = sorted((x0, x1)), sorted((y0, y1)), sorted((z0, z1))
        c = np.array([(x1 if k & 1 else x0, y1 if k & 2 else y0, z1 if k & 4 else z0) for k in range(8)])
        if yaw:
            co, si = math.cos(yaw), math.sin(yaw)
            dx, dy = c[:, 0] - pivot[0], c[:, 1] - pivot[1]
            c[:, 0], c[:, 1] = pivot[0] + co * dx - si * dy, pivot[1] + si * dx + co * dy
        for (a, b, d, e), shade in zip(_FACES, _SHADES, strict=True):
            self.add(c[[a, b, d, a, d, e]], np.clip(np.round(np.asarray(rgb, float) * shade), 0, 255))

    def flat(self, tris2d: np.ndarray, rgb) -> None:
        """Triangles (k, 3, 2) [m] lying flat on the ground."""
        self.add(np.concatenate([tris2d.reshape(-1, 2), np.zeros((tris2d.size // 2, 1))], axis=1), rgb)


class _Build:
    """What one actor is made of: its fixed body and its parts recoloured per frame, by name."""

    def __init__(self) -> None:
        self.body, self.parts = _Mesh(), defaultdict(_Mesh)


@dataclass(frozen=True)
class _Spec:
    asset: str
    length: float  # [m]
    width: float  # [m]
    height: float  # [m]
    color: tuple[int, int, int]
    states: frozenset[str]  # the state names the trace records for this actor
    siren: bool = False


def _tyres(b: _Build, dx: float, s: _Spec, axles: Sequence[float], r: float) -> None:
    for ax in axles:
        for side in (1, -1):
            y = side * (s.width / 2 - 0.02)
            b.body.box(dx + ax - r, dx + ax + r, y, y - side * 0.28, 0.0, 2 * r, TYRE)


def _lamps(b: _Build, dx: float, s: _Spec, z0: float, z1: float, sirens: Sequence[tuple[float, float]]) -> None:
    """Brake lamps (rear), hazard lamps (four corners) and fixed headlamps between heights ``z0``
    and ``z1`` [m]; with a siren, a bar (red left, blue right) at each of ``sirens`` (place along
    the body, roof height) [m]."""
    rear, front, w = dx - s.length / 2, dx + s.length / 2, s.width
    for side in (1, -1):
        y_in, y_mid, y_out = side * 0.16 * w, side * 0.36 * w, side * 0.49 * w
        b.parts["brake"].box(rear - 0.04, rear + 0.02, y_in, y_mid, z0, z1, WHITE)
        for x0, x1 in ((rear - 0.04, rear + 0.02), (front - 0.02, front + 0.04)):
            b.parts["hazard"].box(x0, x1, y_mid, y_out, z0, z1, WHITE)
        b.body.box(front - 0.02, front + 0.03, y_in, y_mid, z0, z1, HEADLAMP)
    for x, z in sirens if s.siren else ():
        b.parts["siren_l"].box(dx + x - 0.25, dx + x + 0.25, 0.0, 0.38 * w, z, z + 0.16, WHITE)
        b.parts["siren_r"].box(dx + x - 0.25, dx + x + 0.25, -0.38 * w, 0.0, z, z + 0.16, WHITE)


def _car(b: _Build, dx: float, s: _Spec) -> None:
    """A body, a glass cabin and a roof; with a door state, the driver's door (left, hinged a fifth
    of the length ahead of the centre, swung out 60 degrees as bird's eye draws it)."""
    L, W, H, c = s.length, s.width, s.height, s.color
    belt = 0.6 * H
    _tyres(b, dx, s, (L / 2 - 0.8, -L / 2 + 0.8), 0.31)
    b.body.box(dx - L / 2, dx + L / 2, -W / 2, W / 2, 0.3, belt, c)
    b.body.box(dx - 0.32 * L, dx + 0.18 * L, -0.45 * W, 0.45 * W, belt, 0.9 * H, GLASS)
    b.body.box(dx - 0.30 * L, dx + 0.14 * L, -0.44 * W, 0.44 * W, 0.9 * H, H, c)
    _lamps(b, dx, s, belt - 0.2, belt - 0.06, [(-0.08 * L, H)])
    if "door" in s.states:
        x, y, dl, yaw = dx + 0.2 * L, W / 2, min(1.1, 0.28 * L), math.radians(120)
        b.parts["door"].box(x, x + dl, y, y + 0.06, 0.3, belt, c, yaw, (x, y))
        b.parts["door"].box(x, x + 0.9 * dl, y, y + 0.05, belt, 0.9 * H, GLASS, yaw, (x, y))


def _truck(b: _Build, dx: float, s: _Spec) -> None:
    """A cab ahead of a taller, lighter cargo box (trucks, fire engines, ambulances)."""
    L, W, H, c = s.length, s.width, s.height, s.color
    cab = dx + 0.26 * L
    _tyres(b, dx, s, (0.38 * L, -0.2 * L, -0.38 * L), 0.45)
    b.body.box(cab, dx + L / 2, -W / 2, W / 2, 0.35, 0.55 * H, c)
    b.body.box(cab, dx + L / 2 - 0.05, -0.47 * W, 0.47 * W, 0.55 * H, 0.78 * H, GLASS)
    b.body.box(cab, dx + L / 2, -W / 2, W / 2, 0.78 * H, 0.85 * H, c)
    b.body.box(dx - L / 2, cab - 0.1, -W / 2, W / 2, 0.45, H, tuple(min(255, round(0.65 * v + 89)) for v in c))
    # siren bars on the cab and at the back of the box: one mid-roof is hidden from behind
    _lamps(b, dx, s, 0.55, 0.8, [(L / 2 - 0.35, 0.85 * H), (-L / 2 + 0.3, H)])


def _bus(b: _Build, dx: float, s: _Spec) -> None:
    L, W, H, c = s.length, s.width, s.height, s.color
    _tyres(b, dx, s, (0.33 * L, -0.3 * L), 0.5)
    b.body.box(dx - L / 2, dx + L / 2, -W / 2, W / 2, 0.3, 0.45 * H, c)
    b.body.box(dx - L / 2 + 0.03, dx + L / 2 - 0.03, -W / 2 + 0.03, W / 2 - 0.03, 0.45 * H, 0.82 * H, GLASS)
    b.body.box(dx - L / 2, dx + L / 2, -W / 2, W / 2, 0.82 * H, H, c)
    _lamps(b, dx, s, 0.6, 0.85, [(L / 2 - 0.4, H), (-L / 2 + 0.4, H)])


def _person(b: _Build, x: float, y: float, height: float, width: float, jacket) -> None:
    """An upright figure: legs, torso and head, ``height`` [m] tall, ``width`` [m] at the shoulders."""
    s, d, head = width / 2, 0.13 * height / 1.8, 0.065 * height
    b.body.box(x - 0.9 * d, x + 0.9 * d, y - 0.8 * s, y + 0.8 * s, 0.0, 0.47 * height, TROUSERS)
    b.body.box(x - d, x + d, y - s, y + s, 0.47 * height, 0.82 * height, jacket)
    b.body.box(x - head, x + head, y - head, y + head, height - 2 * head, height, SKIN)


def _two_wheeler(b: _Build, dx: float, s: _Spec) -> None:
    """Two wheels, a frame and its rider (bicycles, motorcycles)."""
    L, r = s.length, min(0.34, s.length / 5)
    wide = 0.35 if s.asset == "motorcycle" else 0.08
    for ax in (L / 2 - r, -L / 2 + r):
        b.body.box(dx + ax - r, dx + ax + r, -0.05, 0.05, 0.0, 2 * r, TYRE)
    b.body.box(dx - L / 2 + r, dx + L / 2 - r, -wide / 2, wide / 2, r, 2.2 * r, s.color)
    _person(b, dx - 0.05 * L, 0.0, s.height, 0.42, bev.PEDESTRIAN)
    if "brake_lights" in s.states:
        b.parts["brake"].box(dx - L / 2 - 0.04, dx - L / 2 + 0.02, -0.08, 0.08, 2.2 * r, 2.2 * r + 0.1, WHITE)


def _pedestrian(b: _Build, dx: float, s: _Spec) -> None:
    jacket = JACKETS.get(s.asset, bev.PEDESTRIAN)
    if s.length > 1.0 or s.width > 1.0:  # a group: three people inside its footprint
        for fx, fy in ((0.25, 0.25), (-0.25, -0.1), (0.1, -0.3)):
            _person(b, dx + fx * s.length, fy * s.width, s.height, 0.45, jacket)
    else:
        _person(b, dx, 0.0, s.height, max(s.width, 0.3) * 0.9, jacket)


def _traffic_light(b: _Build, dx: float, s: _Spec) -> None:
    """A pole and a signal head with red, yellow and green lamps on all four sides (the trace does
    not say which way it faces), ~1.4 times real size (head 0.5 x 0.5 x 1.25 m, lamps 0.3 m)."""
    H = max(s.height, 2.5)
    b.body.box(dx - 0.07, dx + 0.07, -0.07, 0.07, 0.0, H - 1.2, POLE)
    b.body.box(dx - 0.25, dx + 0.25, -0.25, 0.25, H - 1.25, H, HOUSING)
    for key, z in (("red", H - 0.25), ("yellow", H - 0.625), ("green", H - 1.0)):
        for out in (0.27, -0.27):  # a lamp 4 cm proud of each face
            b.parts[key].box(dx + out - 0.02, dx + out + 0.02, -0.15, 0.15, z - 0.15, z + 0.15, WHITE)
            b.parts[key].box(dx - 0.15, dx + 0.15, out - 0.02, out + 0.02, z - 0.15, z + 0.15, WHITE)


# Static objects as stacks of boxes: (bottom, top) [fraction of height], size [fraction], color.
_STACKS = {
    "traffic_cone": ((0.0, 0.06, 1.0, TYRE), (0.06, 0.4, 0.6, CONE), (0.4, 0.6, 0.42, WHITE), (0.6, 1.0, 0.28, CONE)),
    "barrier": ((0.0, 0.6, 1.0, BARRIER), (0.6, 0.8, 1.0, WHITE), (0.8, 1.0, 1.0, BARRIER)),
    "debris": ((0.0, 1.0, 1.0, (110, 92, 70)),), "box": ((0.0, 1.0, 1.0, (176, 132, 84)),),
}


def _static(b: _Build, dx: float, s: _Spec) -> None:
    for z0, z1, f, color in _STACKS.get(s.asset, ((0.0, 1.0, 1.0, s.color),)):
        b.body.box(dx - f * s.length / 2, dx + f * s.length / 2, -f * s.width / 2, f * s.width / 2,
                   z0 * s.height, z1 * s.height, color)


_Builder = Callable[[_Build, float, _Spec], None]
# Shapes by asset; an asset not named here is drawn by its category's default.
_BY_ASSET: dict[str, _Builder] = {"truck": _truck, "fire_truck": _truck, "tow_truck": _truck,
                                  "ambulance": _truck, "bus": _bus, "bicycle": _two_wheeler,
                                  "motorcycle": _two_wheeler}
_BY_CATEGORY: dict[str, _Builder] = {"pedestrian": _pedestrian, "traffic_light": _traffic_light,
                                     "static": _static}  # the rest: vehicles, drawn as cars
_DEFAULT_HEIGHT = {"pedestrian": 1.8, "traffic_light": 4.0, "static": 1.0}  # [m]


def _build_actor(a: bev.Actor, trace: Trace) -> _Build:
    """The shapes of actor ``a``, sized from its track (its asset's height when the trace has none)."""
    track = trace.actors[a.name]
    height = track.height if track.height > 0 else _DEFAULT_HEIGHT.get(a.category, 1.5)
    s = _Spec(track.asset, a.length, a.width, float(height), bev.BODY.get(a.category, bev.OTHER),
              frozenset(a.states), siren="siren" in a.states or a.category == "emergency")
    builder = _BY_ASSET.get(s.asset) or _BY_CATEGORY.get(a.category, _car)
    b = _Build()
    if a.count > 1:  # a queue: its members bumper to bumper (1 m apart), as bird's eye draws it
        unit = (s.length - (a.count - 1)) / a.count
        member = _Spec(s.asset, unit, s.width, s.height, s.color, s.states, s.siren)
        for k in range(a.count):
            builder(b, -s.length / 2 + unit / 2 + k * (unit + 1.0), member)
    else:
        builder(b, 0.0, s)
    return b


def _triangles(poly, core) -> np.ndarray:
    """A shapely polygon (holes allowed) as triangles (k, 3, 2) [m], by Panda3D's triangulator."""
    t = core.Triangulator()
    for x, y in np.asarray(poly.exterior.coords)[:-1, :2]:
        t.add_polygon_vertex(t.add_vertex(float(x), float(y)))
    for ring in poly.interiors:
        t.begin_hole()
        for x, y in np.asarray(ring.coords)[:-1, :2]:
            t.add_hole_vertex(t.add_vertex(float(x), float(y)))
    t.triangulate()
    verts = np.array([(t.get_vertex(k).x, t.get_vertex(k).y) for k in range(t.get_num_vertices())])
    idx = np.array([(t.get_triangle_v0(k), t.get_triangle_v1(k), t.get_triangle_v2(k))
                    for k in range(t.get_num_triangles())], int).reshape(-1, 3)
    return verts[idx] if len(idx) else np.zeros((0, 3, 2))


def _dashes(line: np.ndarray) -> list[np.ndarray]:
    """The DASH-long pieces of a polyline (n, 2) [m], GAP apart, starting at its first point."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])

    def at(v: float) -> np.ndarray:
        return np.array([[np.interp(v, s, line[:, 0]), np.interp(v, s, line[:, 1])]])

    return [np.vstack([at(a), line[(s > a) & (s < min(a + DASH, s[-1]))], at(min(a + DASH, s[-1]))])
            for a in np.arange(0.0, s[-1], DASH + GAP)]


def _ribbon(line: np.ndarray, width: float) -> np.ndarray:
    """A polyline (n, 2) [m] as a band ``width`` [m] wide: triangles (k, 3, 2), a quad a segment."""
    keep = np.hypot(*np.diff(line, axis=0).T) > 1e-6  # repeated points have no direction
    a, b = line[:-1][keep], line[1:][keep]
    d = b - a
    off = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None] * (width / 2)
    return np.stack([a + off, b + off, b - off, a + off, b - off, a - off], axis=1).reshape(-1, 3, 2)


def _map_meshes(layers: roads.MapLayers, core) -> list[_Mesh]:
    """The map's areas and markings, one mesh a layer, in painting order (bottom first)."""
    out = []
    for name, color in _AREAS:
        out.append(mesh := _Mesh())
        for geom in getattr(layers, name):
            for poly in roads.polygons(geom):
                if len(tris := _triangles(poly, core)):
                    mesh.flat(tris, color)
    for lines, color, width, dashed in ((layers.lane_lines, roads.MARK_WHITE, MARK_W, True),
                                        (layers.curb_lines, roads.MARK_WHITE, MARK_W, False),
                                        (layers.center_lines, roads.MARK_YELLOW, 1.5 * MARK_W, False)):
        out.append(mesh := _Mesh())
        for line in lines:
            for piece in (_dashes(line) if dashed else [line]):
                if len(piece) >= 2:
                    mesh.flat(_ribbon(np.asarray(piece, float), width), color)
    return out


def _ground(layers: roads.MapLayers | None, actors: list[bev.Actor]) -> _Mesh:
    """A flat square reaching GROUND_MARGIN beyond the map and every actor's path."""
    xs, ys = np.concatenate([a.x for a in actors]), np.concatenate([a.y for a in actors])
    x0, y0, x1, y1 = float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())
    for geom in (*layers.roads, *layers.intersections, *layers.sidewalks) if layers is not None else ():
        gx0, gy0, gx1, gy1 = geom.bounds
        x0, y0, x1, y1 = min(x0, gx0), min(y0, gy0), max(x1, gx1), max(y1, gy1)
    x0, y0, x1, y1 = x0 - GROUND_MARGIN, y0 - GROUND_MARGIN, x1 + GROUND_MARGIN, y1 + GROUND_MARGIN
    mesh = _Mesh()
    mesh.flat(np.array([[(x0, y0), (x1, y0), (x1, y1)], [(x0, y0), (x1, y1), (x0, y1)]]), GROUND)
    return mesh


def _lamp(key: str, a: bev.Actor, i: int, t: float) -> tuple[int, int, int]:
    """The color of lamp ``key`` of actor ``a`` at step ``i`` (time ``t`` [s]). Flashing lamps
    keep the bird's-eye rhythm: hazards three times a second, the siren's colours swap four."""
    if key == "brake":
        return bev.BRAKE if bev.is_on(a.state("brake_lights", i)) else BRAKE_OFF
    if key == "hazard":
        return bev.HAZARD if bev.is_on(a.state("hazard_lights", i)) and int(t * 3) % 2 == 0 else HAZARD_OFF
    if key in ("siren_l", "siren_r"):
        on = bev.is_on(a.state("siren", i))
        return (bev.SIREN_RED, bev.SIREN_BLUE)[(int(t * 4) + (key == "siren_r")) % 2] if on else SIREN_OFF
    state = str(a.state("light_state", i) or "off").lower()  # key: the head's red, yellow, green
    return bev.LIGHT_COLORS[key] if {"amber": "yellow"}.get(state, state) == key else LAMP_OFF


class _Renderer:
    """One Panda3D engine, offscreen buffer and camera; scenes are built into it and drawn."""

    def __init__(self, core):
        self.p3 = core
        core.loadPrcFileData("regen-camera", _PRC)
        self.engine = core.GraphicsEngine.get_global_ptr()
        self.pipe = core.GraphicsPipeSelection.get_global_ptr().make_pipe("TinyOffscreenGraphicsPipe",
                                                                          "p3tinydisplay")
        if self.pipe is None:
            raise RegenError("Panda3D's software renderer (p3tinydisplay) could not be loaded")
        self.format = core.GeomVertexFormat.get_v3c4()  # float32 x 3, then uint8 RGBA: 16 bytes
        self.dtype = np.dtype([("p", "<f4", (3,)), ("c", "u1", (4,))])
        self.root = core.NodePath("camera-world")
        self.root.set_two_sided(True)  # triangulated areas come in either winding
        self.lens = core.PerspectiveLens()
        self.lens.set_near_far(NEAR, FAR)
        self.camera = self.root.attach_new_node(core.Camera("ego-camera", self.lens))
        self.size = self.buffer = self.texture = self.map_node = self.scene = self.ego = None
        self.map_key: roads.MapLayers | None = None
        self.posed: list[tuple[bev.Actor, object, dict[str, object]]] = []  # actor, node, parts' nodes

    def _open(self, size: tuple[int, int]) -> None:
        """An offscreen buffer of ``size`` [px] whose frames are copied to RAM (the old one closed)."""
        core = self.p3
        if self.buffer is not None:
            self.engine.remove_window(self.buffer)
        fb = core.FrameBufferProperties()
        fb.set_rgba_bits(8, 8, 8, 0)
        fb.set_depth_bits(24)
        self.buffer = self.engine.make_output(self.pipe, "ego-camera", 0, fb, core.WindowProperties.size(*size),
                                              core.GraphicsPipe.BF_refuse_window)
        if self.buffer is None:
            raise RegenError(f"Panda3D could not open a {size[0]}x{size[1]} offscreen buffer")
        self.texture = core.Texture("ego-camera")
        self.buffer.add_render_texture(self.texture, core.GraphicsOutput.RTM_copy_ram)
        region = self.buffer.make_display_region()
        region.set_camera(self.camera)
        region.set_clear_color_active(True)
        region.set_clear_color((*(v / 255 for v in SKY), 1.0))
        region.set_clear_depth_active(True)
        vfov = math.degrees(2 * math.atan(math.tan(math.radians(HFOV / 2)) * size[1] / size[0]))
        self.lens.set_fov(HFOV, vfov)
        self.size = size

    def _node(self, mesh: _Mesh, name: str):
        """The mesh as a Panda3D GeomNode (unindexed triangles, colours per vertex)."""
        core = self.p3
        pts = np.concatenate(mesh.points)
        data = np.empty(len(pts), self.dtype)
        data["p"], data["c"][:, :3], data["c"][:, 3] = pts, np.concatenate(mesh.colors), 255
        vdata = core.GeomVertexData(name, self.format, core.Geom.UH_static)
        vdata.unclean_set_num_rows(len(data))
        memoryview(vdata.modify_array(0)).cast("B")[:] = data.tobytes()
        prim = core.GeomTriangles(core.Geom.UH_static)
        prim.add_consecutive_vertices(0, len(data))
        geom = core.Geom(vdata)
        geom.add_primitive(prim)
        node = core.GeomNode(name)
        node.add_geom(geom)
        return node

    def _map(self, layers: roads.MapLayers):
        """The map's node, built once and kept while the same map is drawn."""
        if self.map_key is not layers:
            root = self.p3.NodePath("map")
            for order, mesh in enumerate(_map_meshes(layers, self.p3), start=1):
                if mesh.points:
                    root.attach_new_node(self._node(mesh, f"map-{order}")).set_bin("background", order)
            self.map_key, self.map_node = layers, root
        return self.map_node

    def build(self, trace: Trace, layers: roads.MapLayers | None) -> None:
        """The scene of ``trace``: ground, map and every actor but the ego, in which the camera rides."""
        actors = bev.actors_from_trace(trace)
        ego = next((a for a in actors if a.category == "ego"), None)
        if ego is None:
            raise ConfigError("camera: the trace has no ego (an actor named 'ego' or of kind 'ego')")
        if self.scene is not None:
            self.scene.detach_node()
        self.scene = root = self.root.attach_new_node("scene")
        flat = root.attach_new_node("flat")  # under everything: painted in order, no depth test
        flat.set_depth_test(False)
        flat.set_depth_write(False)
        flat.attach_new_node(self._node(_ground(layers, actors), "ground")).set_bin("background", 0)
        if layers is not None:
            self._map(layers).reparent_to(flat)
        self.ego, self.posed = ego, []
        for a in actors:
            if a is ego:
                continue
            b = _build_actor(a, trace)
            node = root.attach_new_node(a.name)
            if b.body.points:
                node.attach_new_node(self._node(b.body, f"{a.name}-body"))
            self.posed.append((a, node, {key: node.attach_new_node(self._node(mesh, f"{a.name}-{key}"))
                                         for key, mesh in b.parts.items() if mesh.points}))

    def draw(self, i: int, t: float, size: tuple[int, int]) -> Image.Image:
        """Frame of step ``i`` (simulated time ``t`` [s]) of the scene built last, at ``size``
        (width, height) [px]."""
        if self.size != size:
            self._open(size)
        for a, node, parts in self.posed:
            node.set_pos_hpr(float(a.x[i]), float(a.y[i]), 0.0, math.degrees(float(a.heading[i])), 0.0, 0.0)
            for key, part in parts.items():
                if key == "door":
                    part.show() if str(a.state("door", i)).lower() == "open" else part.hide()
                else:
                    part.set_color(*(v / 255 for v in _lamp(key, a, i, t)), 1.0)
        e = self.ego
        h, ahead = float(e.heading[i]), EYE_AHEAD * e.length
        # Panda3D's camera looks along its +y: a heading of 0 (east) is a turn of -90 degrees
        self.camera.set_pos_hpr(float(e.x[i]) + ahead * math.cos(h), float(e.y[i]) + ahead * math.sin(h),
                                EYE_HEIGHT, math.degrees(h) - 90.0, 0.0, 0.0)
        self.engine.render_frame()
        raw = bytes(self.texture.get_ram_image_as("RGB"))
        img = Image.frombytes("RGB", (self.texture.get_x_size(), self.texture.get_y_size()), raw)
        return img.transpose(Image.Transpose.FLIP_TOP_BOTTOM)  # textures are stored bottom row first


@cache
def _renderer() -> _Renderer:
    """The process's one renderer, made at first use."""
    try:
        import panda3d.core as core
    except ImportError as exc:
        raise CameraNotInstalled() from exc
    return _Renderer(core)
