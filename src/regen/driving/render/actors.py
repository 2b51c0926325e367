"""The actors of a driving run and how each kind is drawn onto a frame.

:func:`actors_from_trace` turns the trace's tracks into :class:`Actor` arrays with a drawing
category (from the driving asset database); :class:`Canvas` draws on one frame's map window in
world coordinates [m]; :func:`draw_actor` draws one actor at one step: vehicles with their lights,
siren and doors, pedestrians, traffic lights, static objects, and an arrow on the border for an
actor outside the window. Headings are counter-clockwise from +x [rad], as in
:class:`regen.core.trace.Trace`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from regen.core.trace import Trace
from regen.driving.render.roads import FRAME_W, MAP_H, View
from regen.driving.world.actors import actor_category
from regen.driving.world.geometry import to_world
from regen.errors import RegenError
from regen.media import draw_tag_text, text_font, text_length

log = logging.getLogger(__name__)

__all__ = ["Actor", "Canvas", "actors_from_trace", "body_box", "draw_actor", "draw_gnss", "is_on",
           "text_font"]

# Colors (RGB). The ego's fill is used by nothing else so it can be found in the pictures.
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
LIGHT_COLORS = {"red": (230, 20, 20), "yellow": (250, 200, 0), "amber": (250, 200, 0),
                "green": (40, 230, 90), "off": (60, 60, 60)}

BODY = {"ego": EGO, "emergency": EMERGENCY, "vehicle": VEHICLE, "parked": PARKED,
        "pedestrian": PEDESTRIAN, "static": STATIC, "other": OTHER}
_DRAW_ORDER = {"static": 0, "parked": 0, "traffic_light": 1, "other": 2, "vehicle": 3,
               "emergency": 4, "pedestrian": 5, "ego": 6}
_DEFAULT_SIZE = {"pedestrian": (0.6, 0.6), "static": (1.0, 1.0), "traffic_light": (0.6, 0.6)}
_ON = {"on", "true", "yes", "active", "1", "open", "flashing"}
_VEHICLES = ("ego", "emergency", "vehicle", "parked", "other")  # categories drawn as a car


@dataclass
class Actor:
    name: str
    category: str  # ego, emergency, vehicle, parked, pedestrian, static, traffic_light, other
    length: float  # [m]
    width: float  # [m]
    x: np.ndarray  # [m] per step
    y: np.ndarray  # [m]
    heading: np.ndarray  # [rad]
    speed: np.ndarray  # [m/s]
    states: dict[str, list]
    count: int = 1  # a group asset (a queue of cars) is drawn as this many, one behind the other

    def state(self, key: str, i: int):
        seq = self.states.get(key)
        return None if seq is None else seq[i]


def is_on(value: object) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return value != 0
    return isinstance(value, str) and value.strip().lower() in _ON


def _category(name: str, kind: str, asset: str, db) -> str:
    """The drawing category: :func:`regen.driving.world.actors.actor_category` told apart further
    by what the asset database gives it; 'other' for an asset it does not know."""
    if name == "ego" or kind == "ego":
        return "ego"
    spec = db.assets.get(asset) if db is not None else None
    if spec is None:
        return "other"
    cat = actor_category(asset, kind)
    if cat == "vehicle" and "siren" in spec.properties:  # emergency vehicles have a siren
        return "emergency"
    if cat == "static" and "door" in spec.properties:
        # a static object with doors is a parked vehicle: draw it as one (doors, hazards)
        return "parked"
    return "traffic_light" if cat == "light" else cat


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


def actors_from_trace(trace: Trace) -> list[Actor]:
    """The trace's drawable actors (sensors left out), in drawing order: the ego last, on top."""
    try:
        from regen.driving.assets import database as driving_database

        db = driving_database()
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
        spec = db.assets.get(track.asset) if db is not None else None
        out.append(Actor(name, cat, float(length), float(width), x, y, heading, speed,
                         dict(track.states), count=spec.count if spec is not None else 1))
    out.sort(key=lambda a: _DRAW_ORDER.get(a.category, 2))
    return out


def _rect(cx, cy, h, length, width, along=0.0, across=0.0) -> list[tuple[float, float]]:
    """Corners [m] of a length x width rectangle centred ``along``/``across`` from (cx, cy), in
    the order of :func:`regen.driving.world.geometry.corners` and with its arithmetic, on plain
    floats: a frame draws dozens of these, and numpy's overhead on four points was most of it."""
    c, s = math.cos(h), math.sin(h)
    ox, oy = cx + along * c - across * s, cy + along * s + across * c
    out = []
    for lo, la in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        a, b = lo * length / 2, la * width / 2
        out.append((ox + a * c - b * s, oy + a * s + b * c))
    return out


class Canvas:
    """Draws actors onto one cropped background image."""

    def __init__(self, img: Image.Image, view: View, left: int, top: int):
        self.img = img
        self.draw = ImageDraw.Draw(img, "RGBA")  # RGBA mode blends translucent fills
        self.view, self.left, self.top = view, left, top
        self.labels: list[tuple[float, float, float, float]] = []  # tags drawn [px]
        self.bodies: list[tuple[float, float, float, float]] = []  # actors drawn [px], tags avoid them

    def px(self, x: float, y: float) -> tuple[float, float]:
        """Frame pixel of world point (x, y) [m]: :meth:`View.to_px`'s arithmetic on floats."""
        v = self.view
        return (x - v.x0) * v.scale - self.left, (v.y1 - y) * v.scale - self.top

    def poly(self, corners, fill, outline=None, width=1):
        self.draw.polygon([self.px(x, y) for x, y in corners], fill=fill, outline=outline, width=width)

    def disk(self, x, y, r_px, fill, outline=None):
        px, py = self.px(x, y)
        self.draw.ellipse([px - r_px, py - r_px, px + r_px, py + r_px], fill=fill, outline=outline)

    def inside(self, x, y, pad=0.0) -> bool:
        px, py = self.px(x, y)
        return -pad <= px <= FRAME_W + pad and -pad <= py <= MAP_H + pad

    def label(self, text: str, x: float, y: float, box: tuple[float, float, float, float], color) -> None:
        """A name tag beside the actor at (x, y) [m] whose body covers the pixel ``box``: above it,
        else below, right or left, else stacked further above or below with a thin line to it,
        on the first spot that covers no other tag and no other actor's body (:attr:`bodies`);
        when every spot covers one, the spot that covers fewest."""
        font = text_font(11)
        px, py = self.px(x, y)
        w = text_length(text, font, self.draw.mode) + 6
        h = 14
        x0, y0, x1, y1 = box
        spots = [(px - w / 2, y0 - h - 2), (px - w / 2, y1 + 2), (x1 + 4, py - h / 2), (x0 - 4 - w, py - h / 2)]
        for k in range(1, 5):  # stacked further away: a leader line shows whose tag it is
            spots += [(px - w / 2, y0 - h - 2 - k * (h + 2)), (px - w / 2, y1 + 2 + k * (h + 2))]
        best, best_cost = None, None
        for n, (bx, by) in enumerate(spots):
            # kept inside the map window so a tag at the border stays readable; on whole pixels
            # (up and left: the gap above a body never narrows), where its text is stamped
            bx, by = math.floor(min(max(bx, 1), FRAME_W - w - 1)), math.floor(min(max(by, 1), MAP_H - h - 1))
            rect = (bx, by, bx + w, by + h)
            tags = sum(_overlap(rect, r) for r in self.labels)
            bodies = sum(_overlap(rect, b) for b in self.bodies if b != box)
            cost = (tags, bodies, n)
            if best_cost is None or cost < best_cost:
                best, best_cost = (rect, n >= 4), cost
            if tags == 0 and bodies == 0:
                break
        rect, far = best
        self.labels.append(rect)
        if far:  # a leader line from the tag's nearest edge to the actor
            ty = rect[3] if rect[3] <= py else rect[1]
            self.draw.line([(px, py), ((rect[0] + rect[2]) / 2, ty)], fill=(*color, 220), width=1)
        self.draw.rectangle(rect, fill=(20, 20, 24, 170), outline=(*color, 255))
        draw_tag_text(self.draw, (rect[0] + 3, rect[1] + 1), text, (255, 255, 255), font)


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def body_box(f: Canvas, a: Actor, i: int) -> tuple[float, float, float, float]:
    """The pixel box (left, top, right, bottom) around actor ``a``'s body at step ``i``, at least
    as big as it is drawn (a few pixels when zoomed out)."""
    s = f.view.scale
    length, width = max(a.length, 8 / s), max(a.width, 5 / s)
    if a.category in ("pedestrian", "traffic_light"):
        r = max(5.0, 0.5 * max(length, width) * s) + 3
        px, py = f.px(float(a.x[i]), float(a.y[i]))
        return px - r, py - r, px + r, py + r
    pts = [f.px(x, y) for x, y in _rect(float(a.x[i]), float(a.y[i]), float(a.heading[i]), length, width)]
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    return min(xs) - 2, min(ys) - 2, max(xs) + 2, max(ys) + 2


def _draw_vehicle(f: Canvas, a: Actor, i: int, t: float) -> None:
    if a.count > 1:  # a queue: its members bumper to bumper (1 m apart) along its body
        unit = (a.length - (a.count - 1)) / a.count
        x, y, h = float(a.x[i]), float(a.y[i]), float(a.heading[i])
        for k in range(a.count):
            along = -a.length / 2 + unit / 2 + k * (unit + 1.0)
            cx, cy = to_world(x, y, h, along, 0.0)
            member = Actor(a.name, a.category, unit, a.width, a.x.copy(), a.y.copy(), a.heading, a.speed,
                           a.states)
            member.x[i], member.y[i] = cx, cy
            _draw_vehicle(f, member, i, t)
        return
    x, y, h = float(a.x[i]), float(a.y[i]), float(a.heading[i])
    s = f.view.scale
    length, width = max(a.length, 8 / s), max(a.width, 5 / s)  # never smaller than a few pixels
    body = BODY.get(a.category, OTHER)
    siren = is_on(a.state("siren", i))
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
    if is_on(a.state("brake_lights", i)):
        for side in (0.33, -0.33):
            f.poly(_rect(x, y, h, band, 0.3 * width, along=-0.5 * length + band / 2,
                         across=side * width), BRAKE, (120, 0, 0))
    if is_on(a.state("hazard_lights", i)) and int(t * 3) % 2 == 0:
        for along in (0.45, -0.45):
            for across in (0.45, -0.45):
                f.disk(*to_world(x, y, h, along * length, across * width), max(2.5, 0.3 * s), HAZARD)
    if str(a.state("door", i)).lower() == "open":
        # driver's door, hinged a quarter from the front on the left, swung out 60 degrees
        hx, hy = to_world(x, y, h, 0.2 * length, 0.5 * width)
        door = max(1.0, 6 / s)
        ang = h + math.pi - math.radians(60)
        f.draw.line([f.px(hx, hy), f.px(hx + door * math.cos(ang), hy + door * math.sin(ang))],
                    fill=(255, 230, 0), width=3)


def _draw_pedestrian(f: Canvas, a: Actor, i: int) -> None:
    x, y, h = float(a.x[i]), float(a.y[i]), float(a.heading[i])
    r = max(4.0, 0.5 * max(a.length, a.width) * f.view.scale)
    f.disk(x, y, r, PEDESTRIAN, OUTLINE)
    px, py = f.px(x, y)
    f.draw.line([(px, py), (px + r * 1.4 * math.cos(h), py - r * 1.4 * math.sin(h))],
                fill=OUTLINE, width=2)


def _draw_static(f: Canvas, a: Actor, i: int) -> None:
    s = f.view.scale
    f.poly(_rect(float(a.x[i]), float(a.y[i]), float(a.heading[i]), max(a.length, 5 / s),
                 max(a.width, 5 / s)), STATIC, OUTLINE)


def _draw_light(f: Canvas, a: Actor, i: int) -> None:
    state = str(a.state("light_state", i) or "off").lower()
    color = LIGHT_COLORS.get(state, LIGHT_COLORS["off"])
    r = max(5.0, 0.8 * f.view.scale)
    px, py = f.px(float(a.x[i]), float(a.y[i]))
    f.draw.rounded_rectangle([px - r - 3, py - r - 3, px + r + 3, py + r + 3], radius=3,
                             fill=(25, 25, 25), outline=(240, 240, 240))
    f.draw.ellipse([px - r, py - r, px + r, py + r], fill=color)


def draw_gnss(f: Canvas, a: Actor, i: int) -> None:
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
    gx0, gy0 = px + 14 * math.cos(away) - 13, py + 14 * math.sin(away) - 6
    f.draw.text((gx0, gy0), "GNSS", fill=GNSS, font=text_font(10))
    f.labels.append((gx0, gy0, gx0 + 28, gy0 + 12))  # name tags keep off it


def _draw_offscreen(f: Canvas, a: Actor, i: int) -> None:
    """An arrow on the border pointing at an actor outside the window, with its distance."""
    px, py = f.px(float(a.x[i]), float(a.y[i]))
    cx, cy = FRAME_W / 2, MAP_H / 2
    ang = math.atan2(py - cy, px - cx)
    k = min((FRAME_W / 2 - 14) / max(abs(math.cos(ang)), 1e-9),
            (MAP_H / 2 - 14) / max(abs(math.sin(ang)), 1e-9))
    ex, ey = cx + k * math.cos(ang), cy + k * math.sin(ang)
    tip = (ex + 9 * math.cos(ang), ey + 9 * math.sin(ang))
    side = [(ex + 6 * math.cos(ang + d), ey + 6 * math.sin(ang + d)) for d in (2.2, -2.2)]
    color = LIGHT_COLORS["off"] if a.category == "traffic_light" else BODY.get(a.category, OTHER)
    f.draw.polygon([tip, *side], fill=color, outline=OUTLINE)
    dist = math.hypot(px - cx, py - cy) / f.view.scale
    text = f"{a.name} {dist:.0f} m"
    font = text_font(10)
    w, h = text_length(text, font, f.draw.mode) + 4, 13
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


def draw_actor(f: Canvas, a: Actor, i: int, t: float) -> bool:
    """Actor ``a`` at step ``i`` (simulated time ``t`` [s]), or an arrow to it on the border when
    it is outside the window; True when the actor itself was drawn."""
    if not f.inside(float(a.x[i]), float(a.y[i]), pad=2.0 * a.length * f.view.scale):
        _draw_offscreen(f, a, i)
        return False
    if a.category in _VEHICLES:
        _draw_vehicle(f, a, i, t)
    elif a.category == "pedestrian":
        _draw_pedestrian(f, a, i)
    elif a.category == "traffic_light":
        _draw_light(f, a, i)
    else:
        _draw_static(f, a, i)
    return True
