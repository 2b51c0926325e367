"""The legend band under a driving animation: what its colours, marks and tags mean.

Only what the run shows is listed (an ambulance's glow only when a siren is on at some step, a
door only when one opens); the ego, its path, the name tags and the stage boxes of the caption
always are. The swatches are drawn with the colours :mod:`regen.driving.render.actors` draws the
actors in, so the legend cannot drift from the picture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from regen import media
from regen.driving.render.actors import (
    BODY,
    BRAKE,
    EGO,
    EGO_OUTLINE,
    EMERGENCY_OUTLINE,
    GNSS,
    HAZARD,
    LIGHT_COLORS,
    OUTLINE,
    PEDESTRIAN,
    SIREN_BLUE,
    SIREN_RED,
    STATIC,
    Actor,
    is_on,
)
from regen.driving.render.roads import FRAME_W, MAP_H, View

__all__ = ["COLLISION", "Legend", "legend_entries", "legend_image"]

ROW_H = 16  # [px] per row of entries
PAD = 5  # [px] above and below the rows
SWATCH_W = 26  # [px]
GAP = 14  # [px] between entries
DOOR = (255, 230, 0)
COLLISION = "collision"  # the entry of the failure pictures' red ring

# entry kind -> its words, in the order the legend lists them
WORDS = {
    "ego": "ego-vehicle (green, with a halo)",
    "path": "ego's path so far",
    "vehicle": "vehicle",
    "emergency": "emergency vehicle (glow: siren on)",
    "parked": "parked car",
    "door": "open door",
    "other": "other actor",
    "pedestrian": "pedestrian (line: heading)",
    "static": "object",
    "traffic_light": "traffic light (its state)",
    "brake": "brake lights",
    "hazard": "hazard lights",
    "gnss": "GNSS fix (line to the true position)",
    "offscreen": "actor out of view, its distance",
    "tag": "name tag (border: its colour)",
    "distracted": "'(distracted)' on a tag: its driver is",
    COLLISION: "collision",
    "stages": "FSM stages in the caption: reached, not yet, never",
}


@dataclass(frozen=True)
class Legend:
    """The legend band: its entry kinds (keys of :data:`WORDS`) and its image."""

    entries: tuple[str, ...]
    image: Image.Image

    @property
    def height(self) -> int:
        return self.image.height


def _ever(a: Actor, key: str, test) -> bool:
    seq = a.states.get(key)
    return bool(seq) and any(test(v) for v in seq)


def _out_of_view(actors: list[Actor], view: View) -> bool:
    """Whether some actor leaves the map window at some step (it is then an arrow on the border)."""
    lead = next((a for a in actors if a.name == view.follow), None)
    for a in actors:
        px, py = view.to_px(a.x, a.y)
        if lead is not None:
            win = np.array([view.window(float(x), float(y)) for x, y in zip(lead.x, lead.y, strict=True)])
            px, py = px - win[:, 0], py - win[:, 1]
        pad = 2.0 * a.length * view.scale
        if np.any((px < -pad) | (px > FRAME_W + pad) | (py < -pad) | (py > MAP_H + pad)):
            return True
    return False


def legend_entries(actors: list[Actor], view: View, *, collision: bool = False) -> tuple[str, ...]:
    """The kinds of mark the run's pictures show, in the legend's order."""
    cats = {a.category for a in actors}
    kinds = {"ego", "path", "tag", "stages"} if "ego" in cats else {"tag", "stages"}
    kinds |= cats & {"vehicle", "emergency", "parked", "other", "pedestrian", "static", "traffic_light"}
    checks = {
        "brake": ("brake_lights", is_on),
        "hazard": ("hazard_lights", is_on),
        "door": ("door", lambda v: str(v).lower() == "open"),
        "gnss": ("gnss_x", lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)),
        "distracted": ("driver_state", lambda v: v == "distracted"),
    }
    for kind, (key, test) in checks.items():
        if any(_ever(a, key, test) for a in actors):
            kinds.add(kind)
    if _out_of_view(actors, view):
        kinds.add("offscreen")
    if collision:
        kinds.add(COLLISION)
    return tuple(k for k in WORDS if k in kinds)


def _car(d: ImageDraw.ImageDraw, x: int, y: int, body, outline, width: int = 1) -> None:
    d.rectangle([x + 4, y + 4, x + 22, y + 12], fill=body, outline=outline, width=width)
    d.rectangle([x + 16, y + 5, x + 18, y + 11], fill=(30, 36, 48))  # windscreen: it faces right


def _swatch(d: ImageDraw.ImageDraw, kind: str, x: int, y: int) -> None:
    """The mark of ``kind`` in the 26 x 16 px box at (x, y)."""
    cx, cy = x + SWATCH_W // 2, y + ROW_H // 2
    if kind == "ego":
        d.ellipse([cx - 12, cy - 8, cx + 12, cy + 8], fill=tuple(int(0.35 * c + 0.65 * b) for c, b in
                                                                  zip(EGO, media.CAPTION_BG, strict=True)))
        _car(d, x, y, EGO, EGO_OUTLINE, 2)
    elif kind == "path":
        d.line([(x + 2, cy), (x + 24, cy)], fill=EGO, width=2)
    elif kind in ("vehicle", "parked", "other"):
        _car(d, x, y, BODY[kind], OUTLINE)
    elif kind == "emergency":
        d.ellipse([cx - 12, cy - 8, cx + 12, cy + 8], fill=tuple(int(0.4 * c + 0.6 * b) for c, b in
                                                                  zip(SIREN_RED, media.CAPTION_BG, strict=True)))
        _car(d, x, y, BODY["emergency"], EMERGENCY_OUTLINE, 2)
        d.rectangle([x + 10, y + 5, x + 12, y + 7], fill=SIREN_RED)
        d.rectangle([x + 10, y + 9, x + 12, y + 11], fill=SIREN_BLUE)
    elif kind == "door":
        _car(d, x, y, BODY["parked"], OUTLINE)
        d.line([(x + 17, y + 4), (x + 12, y)], fill=DOOR, width=3)
    elif kind == "pedestrian":
        d.ellipse([cx - 5, cy - 5, cx + 5, cy + 5], fill=PEDESTRIAN, outline=OUTLINE)
        d.line([(cx, cy), (cx + 8, cy)], fill=OUTLINE, width=2)
    elif kind == "static":
        d.rectangle([cx - 5, cy - 5, cx + 5, cy + 5], fill=STATIC, outline=OUTLINE)
    elif kind == "traffic_light":
        d.rounded_rectangle([cx - 8, cy - 8, cx + 8, cy + 7], radius=3, fill=(25, 25, 25), outline=(240, 240, 240))
        d.ellipse([cx - 5, cy - 5, cx + 4, cy + 4], fill=LIGHT_COLORS["red"])
    elif kind == "brake":
        _car(d, x, y, BODY["vehicle"], OUTLINE)
        d.rectangle([x + 4, y + 5, x + 6, y + 7], fill=BRAKE)
        d.rectangle([x + 4, y + 9, x + 6, y + 11], fill=BRAKE)
    elif kind == "hazard":
        _car(d, x, y, BODY["vehicle"], OUTLINE)
        for hx in (x + 5, x + 21):
            for hy in (y + 5, y + 11):
                d.ellipse([hx - 2, hy - 2, hx + 2, hy + 2], fill=HAZARD)
    elif kind == "gnss":
        d.ellipse([cx - 5, cy - 5, cx + 5, cy + 5], outline=GNSS, width=2)
        d.line([(cx - 8, cy), (cx + 8, cy)], fill=GNSS)
        d.line([(cx, cy - 8), (cx, cy + 7)], fill=GNSS)
    elif kind == "offscreen":
        tip, back = (x + 22, cy), x + 10
        d.polygon([tip, (back, cy - 6), (back, cy + 6)], fill=BODY["vehicle"], outline=OUTLINE)
    elif kind in ("tag", "distracted"):
        d.rectangle([x + 1, y + 2, x + 25, y + 14], fill=(20, 20, 24), outline=BODY["vehicle"])
        d.text((x + 4, y + 2), "car1", fill=(255, 255, 255), font=media.text_font(9))
    elif kind == COLLISION:
        d.ellipse([cx - 7, cy - 7, cx + 7, cy + 7], outline=media.STAGE_FAILED, width=3)
    elif kind == "stages":
        for k, fill in enumerate((media.STAGE_DONE, media.STAGE_TODO, media.STAGE_FAILED)):
            d.rectangle([x - 10 + 12 * k, cy - 5, x - 10 + 12 * k + 10, cy + 5], fill=fill,
                        outline=(200, 200, 200))


def legend_image(entries: tuple[str, ...], width: int = FRAME_W) -> Legend:
    """The band listing ``entries`` left to right, wrapped into rows ``width`` [px] wide."""
    font = media.text_font(10)
    probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    spots: list[tuple[str, int, int]] = []  # kind, x, row
    x, row = 8, 0
    for kind in entries:
        lead = 12 if kind == "stages" else 0  # the three stage boxes stick out to the left
        need = lead + SWATCH_W + 4 + int(math.ceil(probe.textlength(WORDS[kind], font=font)))
        if x > 8 and x + need > width - 8:
            x, row = 8, row + 1
        spots.append((kind, x + lead, row))
        x += need + GAP
    rows = (row + 1) if spots else 0
    img = Image.new("RGB", (width, 2 * PAD + rows * ROW_H), media.CAPTION_BG)
    d = ImageDraw.Draw(img)
    d.line([(0, 0), (width, 0)], fill=(60, 60, 60))
    for kind, sx, r in spots:
        y = PAD + r * ROW_H
        _swatch(d, kind, sx, y)
        d.text((sx + SWATCH_W + 4, y + 2), WORDS[kind], fill=media.CAPTION_FG, font=font)
    return Legend(entries, img)
