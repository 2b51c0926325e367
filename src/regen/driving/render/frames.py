"""One frame of a driving run: the map window around the actors, their name tags, a scale bar
and a caption with the time, the ego's speed, the verdict and one box per FSM stage (the caption
band every domain's frames share, :func:`regen.media.draw_caption`); an animation's frames also
carry the legend band (:mod:`regen.driving.render.legend`).

Also what the frames have in common: the view (fixed, or following the ego on long runs), the
key-frame picks (start, each FSM stage reached, end) and one GIF palette for all frames.
:class:`Frames` draws the frames of one run, working out what they share once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from PIL import Image

from regen import media
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.driving.render.actors import (
    BODY,
    BRAKE,
    EGO,
    EGO_OUTLINE,
    EMERGENCY,
    EMERGENCY_OUTLINE,
    GNSS,
    HAZARD,
    LIGHT_COLORS,
    OTHER,
    OUTLINE,
    PARKED,
    PEDESTRIAN,
    SIREN_BLUE,
    SIREN_RED,
    STATIC,
    VEHICLE,
    Actor,
    Canvas,
    body_box,
    draw_actor,
    draw_gnss,
    text_font,
)
from regen.driving.render.legend import Legend
from regen.driving.render.roads import (
    CROSSING,
    FRAME_H,
    FRAME_W,
    GRASS,
    JUNCTION,
    MAP_H,
    MARK_WHITE,
    MARK_YELLOW,
    ROAD,
    SHOULDER,
    SIDEWALK,
    View,
)
from regen.driving.world.setting import DrivingWorld

__all__ = ["Frames", "Story", "choose_view", "frame", "keyframe_steps", "palette", "story_of"]

MARGIN = 10.0  # free space around the actors when the view fits them [m]
MIN_FIT_SCALE = 4.0  # below this [px/m] a fixed view is unreadable; follow the ego instead
MAX_SCALE = 14.0  # closest zoom [px/m]; a car is then ~65 px long
FOLLOW_SCALE = 9.0  # zoom of the ego-following view [px/m]: ~71 m x 47 m visible
MAX_BACKGROUND_PX = 6000  # cap on the pre-rendered background's side [px]

# Colors (RGB) of the caption: the band every domain's frames share.
CAPTION_BG, CAPTION_FG = media.CAPTION_BG, media.CAPTION_FG
STAGE_DONE, STAGE_TODO, STAGE_FAILED = media.STAGE_DONE, media.STAGE_TODO, media.STAGE_FAILED


def choose_view(actors: list[Actor]) -> View:
    """A fixed view fitting every actor's whole path when that is readable (at least
    ``MIN_FIT_SCALE`` [px/m]); else a view following the ego over a background around its path."""
    xs = np.concatenate([a.x for a in actors])
    ys = np.concatenate([a.y for a in actors])
    bx0, bx1 = float(xs.min()) - MARGIN, float(xs.max()) + MARGIN
    by0, by1 = float(ys.min()) - MARGIN, float(ys.max()) + MARGIN
    fit = min(FRAME_W / (bx1 - bx0), MAP_H / (by1 - by0))
    if fit >= MIN_FIT_SCALE:
        scale = min(fit, MAX_SCALE)
        cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
        hw, hh = FRAME_W / 2 / scale, MAP_H / 2 / scale
        return View(scale, cx - hw, cy + hh, FRAME_W, MAP_H, None)
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
    return View(scale, float(x0), float(y1), int(math.ceil((x1 - x0) * scale)),
                 int(math.ceil((y1 - y0) * scale)), lead.name)


def _draw_scale_bar(f: Canvas) -> None:
    meters = 10 if f.view.scale >= 5 else 20 if f.view.scale >= 2.5 else 50
    length = meters * f.view.scale
    x0, y0 = 10, MAP_H - 12
    f.draw.rectangle([x0 - 4, y0 - 16, x0 + length + 4, y0 + 6], fill=(255, 255, 255, 170))
    f.draw.line([(x0, y0), (x0 + length, y0)], fill=(20, 20, 24), width=3)
    media.draw_tag_text(f.draw, (x0, y0 - 15), f"{meters} m", (20, 20, 24), text_font(10))


@dataclass(frozen=True)
class Story:
    """What the caption needs: the scenario's name, the stages and the verdict."""

    title: str
    map_name: str
    stages: list[tuple[int, float | None, str]]  # index, reached_at [s], 'actor: state, ...'
    status: str
    failed_stage: int | None
    t_end: float

    @property
    def bar(self) -> media.StageBar:
        """What the caption band shows."""
        return media.StageBar(self.stages, self.status, self.failed_stage, self.t_end)


def story_of(scenario: Scenario, trace: Trace, verdict: Verdict) -> Story:
    """What the caption tells: the verdict's stages, or the FSM's when the verdict has none."""
    stages = [(s.index, s.reached_at, ", ".join(s.conditions)) for s in verdict.stages]
    if not stages:  # a verdict without stage results: list the FSM's stages, none reached
        stages = [(k + 1, None, ", ".join(f"{c.actor}: {c.state}" for c in st.conditions))
                  for k, st in enumerate(scenario.fsm.stages)]
    return Story(scenario.id, str(trace.meta.get("map", DrivingWorld.of(scenario).map or "")), stages,
                  verdict.status, verdict.first_unmet_stage, float(trace.times[-1]))


def _caption(img: Image.Image, story: Story, t: float, ego_speed: float | None) -> None:
    media.draw_caption(img, MAP_H, story.bar, t, "" if ego_speed is None else f"ego {ego_speed:4.1f} m/s")


class Frames:
    """The frames of one run, drawn from what they all share, worked out once: the map window
    with the legend band below it (a fixed view's never moves), the ego's path in background
    pixels and the followed actor. ``Frames(...).draw(i)`` gives the same pixels as
    :func:`frame`; an animation of a hundred frames pays for the shared parts once."""

    def __init__(self, bg: Image.Image, view: View, actors: list[Actor], story: Story, times: np.ndarray,
                 legend: Legend | None = None):
        self.bg, self.view, self.actors, self.story, self.times = bg, view, actors, story, times
        self.legend = legend
        self.lead = next((a for a in actors if a.name == view.follow), None)
        self.ego = next((a for a in actors if a.category == "ego"), None)
        if self.ego is not None:  # the path in background pixels; a frame subtracts its window
            xs, ys = view.to_px(self.ego.x, self.ego.y)
            self.path = np.column_stack([np.asarray(xs, float), np.asarray(ys, float)])
        self._base: tuple[tuple[int, int], Image.Image] | None = None

    def window(self, i: int) -> tuple[int, int]:
        """Top-left background pixel of step ``i``'s map window."""
        if self.lead is None:
            return 0, 0
        return self.view.window(float(self.lead.x[i]), float(self.lead.y[i]))

    def base(self, left: int, top: int) -> Image.Image:
        """A fresh copy of the empty frame: the map window at (left, top) and the legend band."""
        if self._base is None or self._base[0] != (left, top):
            legend = self.legend
            img = Image.new("RGB", (FRAME_W, FRAME_H + (legend.height if legend else 0)), GRASS)
            if legend is not None:
                img.paste(legend.image, (0, FRAME_H))
            img.paste(self.bg.crop((left, top, left + FRAME_W, top + MAP_H)), (0, 0))
            self._base = ((left, top), img)
        return self._base[1].copy()

    def draw(self, i: int, title: str | None = None) -> Image.Image:
        """One full frame (map window and caption, and the legend band below them) at step ``i``."""
        left, top = self.window(i)
        img = self.base(left, top)
        f = Canvas(img, self.view, left, top)
        t = float(self.times[i])
        ego = self.ego
        if ego is not None and i > 0:  # the ego's path so far
            pts = self.path[: i + 1] - (left, top)
            f.draw.line(pts.ravel().tolist(), fill=(*EGO, 150), width=2)
        shown = [a for a in self.actors if draw_actor(f, a, i, t)]
        if ego is not None:
            draw_gnss(f, ego, i)
        boxes = {a.name: body_box(f, a, i) for a in shown}
        f.bodies.extend(boxes.values())  # a tag covers no actor when it can help it
        for a in reversed(shown):  # ego first: its tag gets the best spot
            color = BODY.get(a.category, (240, 240, 240))
            mind = a.state("driver_state", i)  # a mental state that changes what it does is shown
            f.label(a.name + (f" ({mind})" if mind == "distracted" else ""), float(a.x[i]), float(a.y[i]),
                    boxes[a.name], color)
        _draw_scale_bar(f)
        if title:
            media.draw_title(img, title)
        _caption(img, self.story, t, float(ego.speed[i]) if ego is not None else None)
        return img


def frame(bg: Image.Image, view: View, actors: list[Actor], story: Story, times: np.ndarray,
          i: int, title: str | None = None, legend: Legend | None = None) -> Image.Image:
    """One full frame (map window and caption, and the ``legend`` band below them) at step ``i``;
    for many frames of one run, :class:`Frames` shares the work."""
    return Frames(bg, view, actors, story, times, legend).draw(i, title)


def keyframe_steps(times: np.ndarray, story: Story, count: int) -> list[tuple[int, str]]:
    """Start, the step where each FSM stage was reached, and the end (4-``count`` tiles)."""
    return media.keyframe_steps(times, story.stages, count)


def palette(bg: Image.Image) -> Image.Image:
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
