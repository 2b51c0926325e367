"""Pictures of a driving run: a bird's-eye GIF and a strip of key frames (PNG).

The road is drawn once from the OpenDRIVE map (read with Scenic's road network) into a
background image with matplotlib's Agg canvas; each frame then crops that background and draws
only the actors with Pillow, which keeps drawing far cheaper than the simulation it shows.

Coordinates are map coordinates [m] (x east, y north); headings are counter-clockwise from +x,
as in :class:`regen.core.trace.Trace`.
"""

from __future__ import annotations

import io
import logging
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from regen.core.io import atomic_write_bytes
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.errors import ConfigError, DependencyNotInstalled, RegenError

log = logging.getLogger(__name__)

__all__ = ["render_scenario", "RenderOptions"]

FRAME_W, FRAME_H = 640, 480  # output frame [px]
CAPTION_H = 56  # caption band below the map [px]
MAP_H = FRAME_H - CAPTION_H  # map area [px]
MARGIN = 10.0  # free space around the actors when the view fits them [m]
MIN_FIT_SCALE = 4.0  # below this [px/m] a fixed view is unreadable; follow the ego instead
MAX_SCALE = 14.0  # closest zoom [px/m]; a car is then ~65 px long
FOLLOW_SCALE = 9.0  # zoom of the ego-following view [px/m]: ~71 m x 47 m visible
MAX_BACKGROUND_PX = 6000  # cap on the pre-rendered background's side [px]
MAX_FRAMES = 200  # more frames than this only make the GIF bigger, not clearer
KEYFRAME_GAP = 4  # [px] between tiles of the key-frame strip

# Colors (RGB). The ego's fill is used by nothing else so it can be found in the pictures.
GRASS = (226, 231, 218)
ROAD = (86, 88, 94)
JUNCTION = (98, 100, 108)
SIDEWALK = (200, 196, 188)
CROSSING = (150, 150, 156)
SHOULDER = (120, 122, 126)
MARK_WHITE = (244, 244, 244)
MARK_YELLOW = (240, 196, 40)
EGO = (0, 200, 83)
EGO_OUTLINE = (255, 255, 255)
EMERGENCY = (250, 250, 250)
EMERGENCY_OUTLINE = (214, 32, 32)
VEHICLE = (66, 120, 230)
PEDESTRIAN = (255, 140, 0)
STATIC = (150, 104, 70)
OTHER = (170, 170, 170)
PARKED = (128, 138, 160)
OUTLINE = (20, 20, 24)
BRAKE = (255, 0, 0)
HAZARD = (255, 190, 0)
SIREN_RED = (235, 20, 20)
SIREN_BLUE = (20, 90, 255)
GNSS = (200, 0, 200)
CAPTION_BG = (28, 30, 36)
CAPTION_FG = (240, 240, 240)
STAGE_DONE = (0, 190, 90)
STAGE_TODO = (90, 92, 100)
STAGE_FAILED = (220, 50, 50)
LIGHT_COLORS = {"red": (230, 20, 20), "yellow": (250, 200, 0), "amber": (250, 200, 0),
                "green": (40, 230, 90), "off": (60, 60, 60)}

_BODY = {"ego": EGO, "emergency": EMERGENCY, "vehicle": VEHICLE, "parked": PARKED,
         "pedestrian": PEDESTRIAN, "static": STATIC, "other": OTHER}
_DRAW_ORDER = {"static": 0, "parked": 0, "traffic_light": 1, "other": 2, "vehicle": 3,
               "emergency": 4, "pedestrian": 5, "ego": 6}
_DEFAULT_SIZE = {"pedestrian": (0.6, 0.6), "static": (1.0, 1.0), "traffic_light": (0.6, 0.6)}
_ON = {"on", "true", "yes", "active", "1", "open", "flashing"}


@dataclass(frozen=True)
class RenderOptions:
    """Knobs of the pictures; the defaults give a ~640x480 GIF at 10 frames per simulated second."""

    fps: float = 10.0  # frames per simulated second
    max_frames: int = MAX_FRAMES
    keyframes: int = 6  # at most this many tiles in the strip (at least 4 when the trace allows)


# --- actors ------------------------------------------------------------------------------------


@dataclass
class _Actor:
    name: str
    category: str  # ego, emergency, vehicle, parked, pedestrian, static, traffic_light, other
    length: float  # [m]
    width: float  # [m]
    x: np.ndarray  # [m] per step
    y: np.ndarray  # [m]
    heading: np.ndarray  # [rad]
    speed: np.ndarray  # [m/s]
    states: dict[str, list]

    def state(self, key: str, i: int):
        seq = self.states.get(key)
        return None if seq is None else seq[i]


def _is_on(value: object) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return value != 0
    return isinstance(value, str) and value.strip().lower() in _ON


def _category(name: str, kind: str, asset: str, db) -> str:
    if name == "ego" or kind == "ego":
        return "ego"
    cat = db.category_of(asset) if db is not None else None
    if cat == "vehicles":
        spec = db.assets.get(asset)
        # emergency vehicles are the ones the database gives a siren
        return "emergency" if spec is not None and "siren" in spec.properties else "vehicle"
    if cat == "static objects":
        spec = db.assets.get(asset)
        # a static object with doors is a parked vehicle: draw it as one (doors, hazards)
        return "parked" if spec is not None and "door" in spec.properties else "static"
    return {"pedestrians": "pedestrian", "traffic": "traffic_light",
            "sensors": "sensor"}.get(cat or "", "other")


def _headings(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Headings [rad] from the motion where the trace records none (0 while standing)."""
    dx, dy = np.diff(x, append=x[-1:]), np.diff(y, append=y[-1:])
    h = np.arctan2(dy, dx)
    moving = np.hypot(dx, dy) > 1e-6
    if not moving.any():
        return np.zeros_like(x)
    # carry the last known heading over stops so a parked car does not snap to 0
    idx = np.where(moving, np.arange(len(x)), 0)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(moving))
    h[:first] = h[first]
    return h[idx]


def _actors(trace: Trace) -> list[_Actor]:
    try:
        from regen.assets import load_database

        db = load_database("driving")
    except RegenError as exc:  # pictures without categories beat no pictures
        log.warning("driving asset database unavailable (%s); drawing all actors alike", exc)
        db = None
    out = []
    for name, track in trace.actors.items():
        cat = _category(name, track.kind, track.asset, db)
        if cat == "sensor" or not track.x:
            continue
        x, y = np.asarray(track.x, float), np.asarray(track.y, float)
        heading = np.asarray(track.heading, float) if track.heading else _headings(x, y)
        speed = np.asarray(track.speed, float) if track.speed else np.zeros_like(x)
        length, width = track.length, track.width
        if length <= 0 or width <= 0:
            spec = db.assets.get(track.asset) if db is not None else None
            length, width = (spec.size[0], spec.size[1]) if spec else _DEFAULT_SIZE.get(cat, (4.5, 2.0))
        out.append(_Actor(name, cat, float(length), float(width), x, y, heading, speed,
                          dict(track.states)))
    out.sort(key=lambda a: _DRAW_ORDER.get(a.category, 2))
    return out


# --- the map -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _MapLayers:
    """Shapely polygons and polylines [m] of a road network, free of Scenic objects."""

    roads: tuple
    intersections: tuple
    sidewalks: tuple
    crossings: tuple
    shoulders: tuple
    lane_lines: tuple  # dashed white, between lanes of one direction
    curb_lines: tuple  # solid white, outer edges of the driving lanes
    center_lines: tuple  # solid yellow, between opposite directions


def _coords(polyline) -> np.ndarray:
    return np.asarray(polyline.lineString.coords)[:, :2]


def _markings(road) -> tuple[list, list, list]:
    """Lane lines of one road, classified by which lanes share them.

    Scenic does not order lanes the same way in both directions, so edges are matched by
    position: an edge two lanes of one direction share is a dashed lane line, one shared by
    opposite directions is the yellow centre line, one that only one lane has is the curb edge.
    """
    owners: dict[tuple[float, float], list] = {}
    lines: dict[tuple[float, float], np.ndarray] = {}
    for group in road.laneGroups:
        for lane in group.lanes:
            for edge in (lane.leftEdge, lane.rightEdge):
                mid = edge.lineString.interpolate(0.5, normalized=True)
                key = (round(mid.x * 2) / 2, round(mid.y * 2) / 2)  # 0.5 m buckets
                owners.setdefault(key, []).append(group)
                lines.setdefault(key, _coords(edge))
    lane_lines, curbs, centers = [], [], []
    for key, groups in owners.items():
        if len(groups) == 1:
            curbs.append(lines[key])
        elif all(g is groups[0] for g in groups):
            lane_lines.append(lines[key])
        else:
            centers.append(lines[key])
    return lane_lines, curbs, centers


@lru_cache(maxsize=8)
def _load_layers(path: str, mtime: float) -> _MapLayers:  # mtime: a changed file is reloaded
    try:
        from scenic.domains.driving.roads import Network
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled("scenic", "driving", "reading OpenDRIVE maps for pictures") from exc
    net = Network.fromFile(path)
    lane_lines, curb_lines, center_lines = [], [], []
    for road in net.roads:  # ordinary roads only: no markings inside junctions
        lane_lines_r, curbs_r, centers_r = _markings(road)
        lane_lines += lane_lines_r
        curb_lines += curbs_r
        center_lines += centers_r
    return _MapLayers(
        roads=tuple(r.polygon for r in net.roads),
        intersections=tuple(i.polygon for i in net.intersections),
        sidewalks=tuple(s.polygon for s in net.sidewalks),
        crossings=tuple(c.polygon for c in net.crossings),
        shoulders=tuple(s.polygon for s in net.shoulders),
        lane_lines=tuple(lane_lines),
        curb_lines=tuple(curb_lines),
        center_lines=tuple(center_lines),
    )


def _map_path(scenario: Scenario, trace: Trace) -> Path | None:
    raw = trace.meta.get("map_path")
    if isinstance(raw, str) and raw:
        path = Path(raw)
        if path.is_file():
            return path
        log.warning("map file %s recorded in the trace does not exist; trying the map name", path)
    name = trace.meta.get("map") or scenario.world.get("map")
    if not isinstance(name, str) or not name:
        return None
    try:
        from regen.driving.maps import ensure_map

        return ensure_map(name)
    except (ImportError, RegenError) as exc:
        log.warning("cannot get map %r for the pictures: %s", name, exc)
        return None


def map_layers(scenario: Scenario, trace: Trace) -> _MapLayers | None:
    """The road network the trace ran on, or None (drawn as plain ground) if it cannot be read."""
    path = _map_path(scenario, trace)
    if path is None:
        return None
    try:
        return _load_layers(str(path.resolve()), path.stat().st_mtime)
    except DependencyNotInstalled:
        raise
    except Exception as exc:  # noqa: BLE001 - Scenic's parser raises many types; a bad map
        # must not cost the run its pictures, so draw the actors on plain ground and say why
        log.warning("cannot read map %s (%s: %s); drawing without roads", path, type(exc).__name__, exc)
        return None


# --- view and background -----------------------------------------------------------------------


@dataclass(frozen=True)
class _View:
    """Maps world [m] to background pixels and picks the map window of each frame."""

    scale: float  # [px/m]
    x0: float  # world x [m] of the background's left edge
    y1: float  # world y [m] of the background's top edge
    width: int  # background size [px]
    height: int
    follow: str | None  # name of the followed actor, None for a fixed view

    def to_px(self, x, y):
        return (np.asarray(x) - self.x0) * self.scale, (self.y1 - np.asarray(y)) * self.scale

    def window(self, cx: float, cy: float) -> tuple[int, int]:
        """Top-left background pixel of the map window centred on (cx, cy) [m], kept inside."""
        px, py = self.to_px(cx, cy)
        left = int(round(float(px) - FRAME_W / 2))
        top = int(round(float(py) - MAP_H / 2))
        return (min(max(left, 0), max(self.width - FRAME_W, 0)),
                min(max(top, 0), max(self.height - MAP_H, 0)))


def _choose_view(actors: list[_Actor]) -> _View:
    xs = np.concatenate([a.x for a in actors])
    ys = np.concatenate([a.y for a in actors])
    bx0, bx1 = float(xs.min()) - MARGIN, float(xs.max()) + MARGIN
    by0, by1 = float(ys.min()) - MARGIN, float(ys.max()) + MARGIN
    fit = min(FRAME_W / (bx1 - bx0), MAP_H / (by1 - by0))
    if fit >= MIN_FIT_SCALE:
        scale = min(fit, MAX_SCALE)
        cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
        hw, hh = FRAME_W / 2 / scale, MAP_H / 2 / scale
        return _View(scale, cx - hw, cy + hh, FRAME_W, MAP_H, None)
    # Too spread out for one readable picture: follow the ego (or the first mover) and pre-render
    # the ground around its path, half a window beyond it on each side.
    lead = next((a for a in actors if a.category == "ego"), None)
    if lead is None:
        lead = max(actors, key=lambda a: float(np.ptp(a.x) + np.ptp(a.y)))
    lx0, lx1, ly0, ly1 = lead.x.min(), lead.x.max(), lead.y.min(), lead.y.max()
    scale = FOLLOW_SCALE
    span = max(lx1 - lx0, ly1 - ly0) + FRAME_W / scale
    if span * scale > MAX_BACKGROUND_PX:  # a very long path: zoom out instead of a huge image
        scale = MAX_BACKGROUND_PX / span
    hw, hh = FRAME_W / 2 / scale, MAP_H / 2 / scale
    x0, x1, y0, y1 = lx0 - hw, lx1 + hw, ly0 - hh, ly1 + hh
    return _View(scale, float(x0), float(y1), int(math.ceil((x1 - x0) * scale)),
                 int(math.ceil((y1 - y0) * scale)), lead.name)


def _poly_path(poly):
    from matplotlib.path import Path as MplPath

    rings = [poly.exterior, *poly.interiors]
    return MplPath.make_compound_path(*[MplPath(np.asarray(r.coords)[:, :2], closed=True)
                                        for r in rings])


def _polygons(geom) -> list:
    if geom is None or geom.is_empty:
        return []
    return list(geom.geoms) if hasattr(geom, "geoms") else [geom]


def _background(layers: _MapLayers | None, view: _View) -> Image.Image:
    """The static map at the view's scale, drawn once (antialiased) with matplotlib's Agg canvas."""
    if layers is None:
        img = Image.new("RGB", (view.width, view.height), GRASS)
        _grid(img, view)
        return img
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import PathPatch

    dpi = 100
    fig = Figure(figsize=(view.width / dpi, view.height / dpi), dpi=dpi, facecolor=_rgb01(GRASS))
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    ax.set_xlim(view.x0, view.x0 + view.width / view.scale)
    ax.set_ylim(view.y1 - view.height / view.scale, view.y1)
    for group, color in ((layers.sidewalks, SIDEWALK), (layers.shoulders, SHOULDER),
                         (layers.roads, ROAD), (layers.intersections, JUNCTION),
                         (layers.crossings, CROSSING)):
        for geom in group:
            for poly in _polygons(geom):
                ax.add_patch(PathPatch(_poly_path(poly), facecolor=_rgb01(color),
                                       edgecolor=_rgb01(color), linewidth=0.5))
    pt_per_m = view.scale * 72.0 / dpi  # line widths and dashes are in points
    mark_w = max(0.75, 0.15 * pt_per_m)
    dash = (3.0 * pt_per_m / mark_w, 6.0 * pt_per_m / mark_w)  # 3 m dashes, 6 m gaps
    for line in layers.lane_lines:
        ax.plot(line[:, 0], line[:, 1], color=_rgb01(MARK_WHITE), lw=mark_w, dashes=dash)
    for line in layers.curb_lines:
        ax.plot(line[:, 0], line[:, 1], color=_rgb01(MARK_WHITE), lw=mark_w)
    for line in layers.center_lines:
        ax.plot(line[:, 0], line[:, 1], color=_rgb01(MARK_YELLOW), lw=mark_w * 1.5)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    return Image.fromarray(rgba[..., :3].copy(), "RGB")


def _grid(img: Image.Image, view: _View) -> None:
    """A 10 m grid on plain ground, so distances stay readable without a map."""
    draw = ImageDraw.Draw(img)
    step = 10.0
    x_end = view.x0 + view.width / view.scale
    y_end = view.y1 - view.height / view.scale
    for gx in np.arange(math.ceil(view.x0 / step) * step, x_end, step):
        px, _ = view.to_px(gx, 0)
        draw.line([(float(px), 0), (float(px), view.height)], fill=(210, 216, 202))
    for gy in np.arange(math.ceil(y_end / step) * step, view.y1, step):
        _, py = view.to_px(0, gy)
        draw.line([(0, float(py)), (view.width, float(py))], fill=(210, 216, 202))


def _rgb01(c: tuple[int, int, int]) -> tuple[float, float, float]:
    return (c[0] / 255, c[1] / 255, c[2] / 255)


# --- fonts -------------------------------------------------------------------------------------


@lru_cache(maxsize=8)
def _font(size: int, bold: bool = False):
    """DejaVu Sans from matplotlib's own data (always installed with it), else Pillow's default."""
    try:
        import matplotlib

        name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
        return ImageFont.truetype(str(Path(matplotlib.get_data_path()) / "fonts" / "ttf" / name), size)
    except OSError:
        return ImageFont.load_default(size=size)


# --- drawing one frame -------------------------------------------------------------------------


def _rect(cx, cy, h, length, width, along=0.0, across=0.0):
    """Corners [m] of a length x width rectangle centred ``along``/``across`` from (cx, cy)."""
    c, s = math.cos(h), math.sin(h)
    ox, oy = cx + along * c - across * s, cy + along * s + across * c
    out = []
    for a, b in ((0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)):
        u, v = a * length, b * width
        out.append((ox + u * c - v * s, oy + u * s + v * c))
    return out


class _Frame:
    """Draws actors onto one cropped background image."""

    def __init__(self, img: Image.Image, view: _View, left: int, top: int):
        self.img = img
        self.draw = ImageDraw.Draw(img, "RGBA")  # RGBA mode blends translucent fills
        self.view, self.left, self.top = view, left, top
        self.labels: list[tuple[float, float, float, float]] = []

    def px(self, x: float, y: float) -> tuple[float, float]:
        px, py = self.view.to_px(x, y)
        return float(px) - self.left, float(py) - self.top

    def poly(self, corners, fill, outline=None, width=1):
        self.draw.polygon([self.px(x, y) for x, y in corners], fill=fill, outline=outline, width=width)

    def disk(self, x, y, r_px, fill, outline=None):
        px, py = self.px(x, y)
        self.draw.ellipse([px - r_px, py - r_px, px + r_px, py + r_px], fill=fill, outline=outline)

    def inside(self, x, y, pad=0.0) -> bool:
        px, py = self.px(x, y)
        return -pad <= px <= FRAME_W + pad and -pad <= py <= MAP_H + pad

    def label(self, text: str, x: float, y: float, r_px: float, color) -> None:
        """A name tag above the actor, moved below or aside when it would cover another tag."""
        font = _font(11)
        px, py = self.px(x, y)
        w = self.draw.textlength(text, font=font) + 6
        h = 14
        for dx, dy in ((0, -r_px - h - 2), (0, r_px + 2), (r_px + 4, -h / 2), (-r_px - 4 - w, -h / 2)):
            # kept inside the map window so a tag at the border stays readable
            bx = min(max(px - (w / 2 if dx == 0 else 0) + dx, 1), FRAME_W - w - 1)
            by = min(max(py + dy, 1), MAP_H - h - 1)
            rect = (bx, by, bx + w, by + h)
            if not any(_overlap(rect, r) for r in self.labels):
                break
        self.labels.append(rect)
        self.draw.rectangle(rect, fill=(20, 20, 24, 170), outline=(*color, 255))
        self.draw.text((rect[0] + 3, rect[1] + 1), text, fill=(255, 255, 255), font=font)


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _draw_vehicle(f: _Frame, a: _Actor, i: int, t: float) -> None:
    x, y, h = float(a.x[i]), float(a.y[i]), float(a.heading[i])
    s = f.view.scale
    length, width = max(a.length, 8 / s), max(a.width, 5 / s)  # never smaller than a few pixels
    body = _BODY.get(a.category, OTHER)
    siren = _is_on(a.state("siren", i))
    if siren:  # a glow flashing red/blue twice a second is visible at any zoom
        glow = SIREN_RED if int(t * 4) % 2 == 0 else SIREN_BLUE
        f.disk(x, y, 0.75 * length * s, (*glow, 70))
    if a.category == "ego":  # a halo makes the ego findable at a glance
        f.disk(x, y, 0.7 * length * s, (*EGO, 60))
    outline = EMERGENCY_OUTLINE if a.category == "emergency" else (
        EGO_OUTLINE if a.category == "ego" else OUTLINE)
    f.poly(_rect(x, y, h, length, width), body, outline, 2 if a.category in ("ego", "emergency") else 1)
    # windscreen: a dark band in the front third shows which way the vehicle faces
    f.poly(_rect(x, y, h, 0.14 * length, 0.8 * width, along=0.22 * length), (30, 36, 48))
    if a.category == "emergency":
        bar_l = max(0.35, 2.0 / s)
        left, right = (SIREN_RED, SIREN_BLUE) if int(t * 4) % 2 == 0 else (SIREN_BLUE, SIREN_RED)
        if not siren:
            left = right = (120, 120, 120)
        f.poly(_rect(x, y, h, bar_l, 0.45 * width, across=0.23 * width), left)
        f.poly(_rect(x, y, h, bar_l, 0.45 * width, across=-0.23 * width), right)
    band = max(0.3, 2.0 / s)
    if _is_on(a.state("brake_lights", i)):
        for side in (0.33, -0.33):
            f.poly(_rect(x, y, h, band, 0.3 * width, along=-0.5 * length + band / 2,
                         across=side * width), BRAKE, (120, 0, 0))
    if _is_on(a.state("hazard_lights", i)) and int(t * 3) % 2 == 0:
        for along in (0.45, -0.45):
            for across in (0.45, -0.45):
                f.disk(x + along * length * math.cos(h) - across * width * math.sin(h),
                       y + along * length * math.sin(h) + across * width * math.cos(h),
                       max(2.5, 0.3 * s), HAZARD)
    if str(a.state("door", i)).lower() == "open":
        # driver's door, hinged a quarter from the front on the left, swung out 60 degrees
        hx = x + 0.2 * length * math.cos(h) - 0.5 * width * math.sin(h)
        hy = y + 0.2 * length * math.sin(h) + 0.5 * width * math.cos(h)
        door = max(1.0, 6 / s)
        ang = h + math.pi - math.radians(60)
        f.draw.line([f.px(hx, hy), f.px(hx + door * math.cos(ang), hy + door * math.sin(ang))],
                    fill=(255, 230, 0), width=3)


def _draw_pedestrian(f: _Frame, a: _Actor, i: int) -> None:
    x, y, h = float(a.x[i]), float(a.y[i]), float(a.heading[i])
    r = max(4.0, 0.5 * max(a.length, a.width) * f.view.scale)
    f.disk(x, y, r, PEDESTRIAN, OUTLINE)
    px, py = f.px(x, y)
    f.draw.line([(px, py), (px + r * 1.4 * math.cos(h), py - r * 1.4 * math.sin(h))],
                fill=OUTLINE, width=2)


def _draw_static(f: _Frame, a: _Actor, i: int) -> None:
    s = f.view.scale
    f.poly(_rect(float(a.x[i]), float(a.y[i]), float(a.heading[i]), max(a.length, 5 / s),
                 max(a.width, 5 / s)), STATIC, OUTLINE)


def _draw_light(f: _Frame, a: _Actor, i: int) -> None:
    state = str(a.state("light_state", i) or "off").lower()
    color = LIGHT_COLORS.get(state, LIGHT_COLORS["off"])
    r = max(5.0, 0.8 * f.view.scale)
    px, py = f.px(float(a.x[i]), float(a.y[i]))
    f.draw.rounded_rectangle([px - r - 3, py - r - 3, px + r + 3, py + r + 3], radius=3,
                             fill=(25, 25, 25), outline=(240, 240, 240))
    f.draw.ellipse([px - r, py - r, px + r, py + r], fill=color)


def _draw_gnss(f: _Frame, a: _Actor, i: int) -> None:
    gx, gy = a.state("gnss_x", i), a.state("gnss_y", i)
    if not isinstance(gx, (int, float)) or not isinstance(gy, (int, float)):
        return
    x, y = float(a.x[i]), float(a.y[i])
    f.draw.line([f.px(x, y), f.px(gx, gy)], fill=GNSS, width=1)
    px, py = f.px(gx, gy)
    f.draw.ellipse([px - 5, py - 5, px + 5, py + 5], outline=GNSS, width=2)
    f.draw.line([(px - 8, py), (px + 8, py)], fill=GNSS)
    f.draw.line([(px, py - 8), (px, py + 8)], fill=GNSS)
    # the tag goes on the far side from the true position so it does not cover the ego
    tx, ty = f.px(x, y)
    away = math.atan2(py - ty, px - tx) if (px, py) != (tx, ty) else -math.pi / 2
    f.draw.text((px + 14 * math.cos(away) - 13, py + 14 * math.sin(away) - 6), "GNSS", fill=GNSS,
                font=_font(10))


def _draw_offscreen(f: _Frame, a: _Actor, i: int) -> None:
    """An arrow on the border pointing at an actor outside the window, with its distance."""
    px, py = f.px(float(a.x[i]), float(a.y[i]))
    cx, cy = FRAME_W / 2, MAP_H / 2
    ang = math.atan2(py - cy, px - cx)
    k = min((FRAME_W / 2 - 14) / max(abs(math.cos(ang)), 1e-9),
            (MAP_H / 2 - 14) / max(abs(math.sin(ang)), 1e-9))
    ex, ey = cx + k * math.cos(ang), cy + k * math.sin(ang)
    tip = (ex + 9 * math.cos(ang), ey + 9 * math.sin(ang))
    side = [(ex + 6 * math.cos(ang + d), ey + 6 * math.sin(ang + d)) for d in (2.2, -2.2)]
    color = LIGHT_COLORS["off"] if a.category == "traffic_light" else _BODY.get(a.category, OTHER)
    f.draw.polygon([tip, *side], fill=color, outline=OUTLINE)
    dist = math.hypot(px - cx, py - cy) / f.view.scale
    text = f"{a.name} {dist:.0f} m"
    font = _font(10)
    w, h = f.draw.textlength(text, font=font) + 4, 13
    tx = min(max(ex - w / 2, 2), FRAME_W - w - 2)
    ty = min(max(ey + (10 if ey < cy else -24), 2), MAP_H - h - 2)
    step = 14 if ty < cy else -14  # stack tags toward the middle instead of overlapping
    rect = (tx, ty, tx + w, ty + h)
    for _ in range(12):
        if not any(_overlap(rect, r) for r in f.labels):
            break
        ty += step
        rect = (tx, ty, tx + w, ty + h)
    f.labels.append(rect)
    f.draw.rectangle(rect, fill=(255, 255, 255, 150))
    f.draw.text((tx + 2, ty), text, fill=(20, 20, 24), font=font)


def _draw_scale_bar(f: _Frame) -> None:
    meters = 10 if f.view.scale >= 5 else 20 if f.view.scale >= 2.5 else 50
    length = meters * f.view.scale
    x0, y0 = 10, MAP_H - 12
    f.draw.rectangle([x0 - 4, y0 - 16, x0 + length + 4, y0 + 6], fill=(255, 255, 255, 170))
    f.draw.line([(x0, y0), (x0 + length, y0)], fill=(20, 20, 24), width=3)
    f.draw.text((x0, y0 - 15), f"{meters} m", fill=(20, 20, 24), font=_font(10))


@dataclass(frozen=True)
class _Story:
    """What the caption needs: the scenario's name, the stages and the verdict."""

    title: str
    map_name: str
    stages: list[tuple[int, float | None, str]]  # index, reached_at [s], 'actor: state, ...'
    status: str
    failed_stage: int | None
    t_end: float


def _story(scenario: Scenario, trace: Trace, verdict: Verdict) -> _Story:
    stages = [(s.index, s.reached_at, ", ".join(s.conditions)) for s in verdict.stages]
    if not stages:  # a verdict without stage results: list the FSM's stages, none reached
        stages = [(k + 1, None, ", ".join(f"{c.actor}: {c.state}" for c in st.conditions))
                  for k, st in enumerate(scenario.fsm.stages)]
    return _Story(scenario.id, str(trace.meta.get("map", scenario.world.get("map", ""))), stages,
                  verdict.status, verdict.first_unmet_stage, float(trace.times[-1]))


def _fit(draw: ImageDraw.ImageDraw, text: str, font, width: float) -> str:
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "…", font=font) > width:
        text = text[:-1]
    return text + "…"


def _caption(img: Image.Image, story: _Story, t: float, ego_speed: float | None) -> None:
    draw = ImageDraw.Draw(img)
    draw.rectangle([0, MAP_H, FRAME_W, FRAME_H], fill=CAPTION_BG)
    big, small = _font(13, bold=True), _font(11)
    y1, y2 = MAP_H + 6, MAP_H + 31
    left = f"t = {t:5.1f} s / {story.t_end:.1f} s"
    if ego_speed is not None:
        left += f"   ego {ego_speed:4.1f} m/s"
    draw.text((8, y1), left, fill=CAPTION_FG, font=big)
    ok = story.status == "verified"
    status = story.status.replace("_", " ")
    if story.failed_stage is not None and not ok:
        status += f" (stage {story.failed_stage} unmet)"
    sw = draw.textlength(status, font=small)
    draw.text((FRAME_W - sw - 8, y1 + 2), status, fill=STAGE_DONE if ok else STAGE_FAILED, font=small)
    # one box per FSM stage: green once reached, red for the stage that never was (at the end)
    x = 8
    current = None
    at_end = t >= story.t_end - 1e-9
    for index, reached, _ in story.stages:
        done = reached is not None and reached <= t + 1e-9
        if done:
            current = (index, reached)
        fill = STAGE_DONE if done else (STAGE_FAILED if at_end and index == story.failed_stage
                                        else STAGE_TODO)
        draw.rectangle([x, y2, x + 16, y2 + 16], fill=fill, outline=(200, 200, 200))
        num = str(index)
        draw.text((x + 8 - draw.textlength(num, font=small) / 2, y2 + 2), num, fill=(255, 255, 255),
                  font=small)
        x += 20
    if current is None:
        text = "no stage reached yet" if story.stages else "no FSM stages"
    else:
        conds = next(c for k, _, c in story.stages if k == current[0])
        text = f"stage {current[0]}/{len(story.stages)} at {current[1]:.1f} s: {conds}"
    draw.text((x + 6, y2 + 1), _fit(draw, text, small, FRAME_W - x - 14), fill=CAPTION_FG, font=small)


def _frame(bg: Image.Image, view: _View, actors: list[_Actor], story: _Story, times: np.ndarray,
           i: int, title: str | None = None) -> Image.Image:
    """One full frame (map window and caption) at step ``i``."""
    lead = next((a for a in actors if a.name == view.follow), None)
    if lead is not None:
        left, top = view.window(float(lead.x[i]), float(lead.y[i]))
    else:
        left, top = 0, 0
    img = Image.new("RGB", (FRAME_W, FRAME_H), GRASS)
    img.paste(bg.crop((left, top, left + FRAME_W, top + MAP_H)), (0, 0))
    f = _Frame(img, view, left, top)
    t = float(times[i])
    ego = next((a for a in actors if a.category == "ego"), None)
    if ego is not None and i > 0:  # the ego's path so far
        pts = [f.px(float(px), float(py)) for px, py in zip(ego.x[: i + 1], ego.y[: i + 1], strict=True)]
        f.draw.line(pts, fill=(*EGO, 150), width=2)
    shown = []
    for a in actors:
        if not f.inside(float(a.x[i]), float(a.y[i]), pad=2.0 * a.length * view.scale):
            _draw_offscreen(f, a, i)
            continue
        shown.append(a)
        if a.category in ("ego", "emergency", "vehicle", "parked", "other"):
            _draw_vehicle(f, a, i, t)
        elif a.category == "pedestrian":
            _draw_pedestrian(f, a, i)
        elif a.category == "traffic_light":
            _draw_light(f, a, i)
        else:
            _draw_static(f, a, i)
    if ego is not None:
        _draw_gnss(f, ego, i)
    for a in reversed(shown):  # ego first: its tag gets the best spot
        r = 0.5 * max(a.length, a.width) * view.scale + 2
        color = _BODY.get(a.category, (240, 240, 240))
        f.label(a.name, float(a.x[i]), float(a.y[i]), r, color)
    _draw_scale_bar(f)
    if title:
        font = _font(13, bold=True)
        w = f.draw.textlength(title, font=font)
        f.draw.rectangle([0, 0, w + 12, 20], fill=(20, 20, 24, 200))
        f.draw.text((6, 2), title, fill=(255, 255, 255), font=font)
    _caption(img, story, t, float(ego.speed[i]) if ego is not None else None)
    return img


# --- GIF and key frames ------------------------------------------------------------------------


def _frame_steps(times: np.ndarray, fps: float, max_frames: int) -> np.ndarray:
    """Step indices of the GIF's frames: about ``fps`` per simulated second, last step included."""
    n = len(times)
    dt = float(np.median(np.diff(times))) if n > 1 else 1.0
    stride = max(1, int(round(1.0 / (fps * dt)))) if dt > 0 else 1
    stride = max(stride, math.ceil(n / max_frames))
    steps = np.arange(0, n, stride)
    if steps[-1] != n - 1:
        steps = np.append(steps, n - 1)
    return steps


def _keyframe_steps(times: np.ndarray, story: _Story, count: int) -> list[tuple[int, str]]:
    """Start, the step where each FSM stage was reached, and the end (4-``count`` tiles)."""
    n = len(times)
    picks: dict[int, str] = {0: "start"}
    reached = [(k, r) for k, r, _ in story.stages if r is not None]
    if len(reached) > count - 2:  # too many stages: keep evenly spread ones
        sel = np.linspace(0, len(reached) - 1, count - 2).round().astype(int)
        reached = [reached[j] for j in sorted(set(sel))]
    for k, r in reached:
        i = int(min(np.searchsorted(times, r - 1e-9), n - 1))
        picks.setdefault(i, f"stage {k} reached")
    picks.setdefault(n - 1, "end")
    target = min(4, n)
    while len(picks) < target:  # fill the widest gap so the strip shows the whole run
        idx = sorted(picks)
        gaps = [(idx[j + 1] - idx[j], j) for j in range(len(idx) - 1)]
        width, j = max(gaps)
        if width < 2:
            break
        picks[idx[j] + width // 2] = "during"
    return sorted(picks.items())[:count]


def _palette(bg: Image.Image) -> Image.Image:
    """One palette for every frame: the style's exact colors plus the map's own shades."""
    fixed = [GRASS, ROAD, JUNCTION, SIDEWALK, CROSSING, SHOULDER, MARK_WHITE, MARK_YELLOW, EGO, PARKED,
             EGO_OUTLINE, EMERGENCY, EMERGENCY_OUTLINE, VEHICLE, PEDESTRIAN, STATIC, OTHER, OUTLINE,
             BRAKE, HAZARD, SIREN_RED, SIREN_BLUE, GNSS, CAPTION_BG, CAPTION_FG, STAGE_DONE,
             STAGE_TODO, STAGE_FAILED, (30, 36, 48), (255, 230, 0), (0, 0, 0), (255, 255, 255),
             (120, 0, 0), (25, 25, 25), (60, 60, 60), (120, 120, 120), (200, 200, 200),
             *LIGHT_COLORS.values()]
    fixed = list(dict.fromkeys(fixed))
    # translucent overlays (halo, glow, tags) blend style colors into the ground: sample them
    blends = []
    for c in (EGO, SIREN_RED, SIREN_BLUE, (20, 20, 24)):
        for g in (GRASS, ROAD, SIDEWALK, JUNCTION):
            for w in (0.25, 0.6):
                blends.append(tuple(int(round(w * a + (1 - w) * b)) for a, b in zip(c, g, strict=True)))
    fixed += [b for b in dict.fromkeys(blends) if b not in fixed]
    rest = 256 - len(fixed)
    sample = bg.resize((min(bg.width, 800), min(bg.height, 600)))
    shades = sample.quantize(colors=rest, method=Image.Quantize.MEDIANCUT).getpalette()[: 3 * rest]
    flat = [v for c in fixed for v in c] + shades
    flat += [0] * (768 - len(flat))
    pal = Image.new("P", (1, 1))
    pal.putpalette(flat)
    return pal


def render_scenario(scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path,
                    options: RenderOptions | None = None) -> dict[str, Path]:
    """Draw a driving run: ``bird_eye.gif`` and ``keyframes.png`` in ``out_dir``.

    The GIF plays in simulated real time at about ``options.fps`` frames per simulated second
    (at most ``options.max_frames`` frames) at 640x480 px; the strip shows 4-6 frames of
    640x480 px side by side (start, each FSM stage reached, end) separated by 4 px.
    Returns ``{"gif": path, "keyframes": path}``. A trace without steps or actors raises
    :class:`ConfigError`; a map that cannot be read is drawn as plain ground with a warning.
    """
    options = options or RenderOptions()
    if trace.steps == 0:
        raise ConfigError(f"scenario {scenario.id!r}: the trace has no steps; nothing to draw")
    actors = _actors(trace)
    if not actors:
        raise ConfigError(f"scenario {scenario.id!r}: the trace has no drawable actors")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    times = np.asarray(trace.times, float)
    view = _choose_view(actors)
    bg = _background(map_layers(scenario, trace), view)
    story = _story(scenario, trace, verdict)

    steps = _frame_steps(times, options.fps, options.max_frames)
    pal = _palette(bg)
    frames = [_frame(bg, view, actors, story, times, int(i)).quantize(palette=pal, dither=Image.Dither.NONE)
              for i in steps]
    frame_ms = max(20, int(round(1000 * float(np.median(np.diff(times[steps]))))) if len(steps) > 1 else 1000)
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=frame_ms,
                   loop=0, disposal=1)
    gif = atomic_write_bytes(out_dir / "bird_eye.gif", buf.getvalue())

    picks = _keyframe_steps(times, story, max(1, options.keyframes))
    tiles = [_frame(bg, view, actors, story, times, i, title=title) for i, title in picks]
    strip = Image.new("RGB", (len(tiles) * FRAME_W + (len(tiles) - 1) * KEYFRAME_GAP, FRAME_H),
                      (255, 255, 255))
    for k, tile in enumerate(tiles):
        strip.paste(tile, (k * (FRAME_W + KEYFRAME_GAP), 0))
    buf = io.BytesIO()
    strip.save(buf, format="PNG", optimize=True)
    png = atomic_write_bytes(out_dir / "keyframes.png", buf.getvalue())
    log.info("rendered %s: %d GIF frames (%.0f kB), %d key frames", scenario.id, len(frames),
             gif.stat().st_size / 1024, len(tiles))
    return {"gif": gif, "keyframes": png}
