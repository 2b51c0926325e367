"""Pictures of failed behavior tests: the policy's episode as a bird's-eye GIF.

The scenario's own GIF (:mod:`regen.driving.render.scenario`) shows the scripted template ego that
verified; a failed test needs the episode of the policy under test. It is drawn with the same
map, actors and caption, except that the caption tells the test's verdict and the ego's
expected states as the policy reached them, and from the step of a collision on a red ring marks
where it happened. The shared :func:`regen.harness.pictures.keep_failures` asks for it through
the driving harness (:meth:`regen.driving.testing.harness.DrivingHarness.failure_picture`).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from regen import media
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.driving.render.actors import Actor, Canvas, text_font
from regen.driving.render.frames import STAGE_FAILED, Story, frame, palette
from regen.driving.render.roads import MAP_H, View
from regen.driving.render.scenario import RenderOptions, scene
from regen.driving.world.setting import DrivingWorld
from regen.harness.pictures import FAILURE_GIF, case_folder

if TYPE_CHECKING:
    from regen.harness.cases import CaseResult

log = logging.getLogger(__name__)

__all__ = ["render_failure"]

MARK_RADIUS = 2.5  # [m] of the ring around a collision
MARK_MIN_PX = 12  # [px] the ring stays visible when zoomed out


def story_of_case(scenario: Scenario, trace: Trace, case: CaseResult, policy: str) -> Story:
    """The caption's story: the test's verdict and the ego's expected stages."""
    stages = [(k, s.reached_at, ", ".join(f"ego: {c}" for c in s.conditions))
              for k, s in enumerate(case.robot_stages, start=1)]
    unmet = next((k for k, s in enumerate(case.robot_stages, start=1) if s.reached_at is None), None)
    if case.collision:
        status = f"{policy}: collision with {case.collision_with}"
    else:
        status = f"{policy}: {(case.cause or case.status).replace('_', ' ')}"
    failed_stage = unmet if case.cause == "state_not_reached" else None
    return Story(scenario.id, str(trace.meta.get("map", DrivingWorld.of(scenario).map or "")), stages,
                 status, failed_stage, float(trace.times[-1]))


def _canvas(img: Image.Image, view: View, actors: list[Actor], i: int) -> Canvas:
    """A canvas on a drawn frame with the same map window :func:`frame` used."""
    lead = next((a for a in actors if a.name == view.follow), None)
    left, top = view.window(float(lead.x[i]), float(lead.y[i])) if lead is not None else (0, 0)
    return Canvas(img, view, left, top)


def _label(f: Canvas, text: str, x: float, y: float) -> None:
    """White bold text on a red box with its top-left corner at pixel (x, y)."""
    font = text_font(12, bold=True)
    w = f.draw.textlength(text, font=font)
    f.draw.rectangle([x, y, x + w + 8, y + 16], fill=(*STAGE_FAILED, 255))
    f.draw.text((x + 4, y + 1), text, fill=(255, 255, 255), font=font)


def _mark_collision(img: Image.Image, view: View, actors: list[Actor], i: int, hit: int,
                    pair: tuple[str, str], t_hit: float) -> Image.Image:
    """A tag in the top-left corner from the collision on, and a red ring between the two actors
    where they were at the collision step ``hit`` while that place is in the window."""
    f = _canvas(img, view, actors, i)
    _label(f, f"collision with {pair[1]} at t = {t_hit:.1f} s", 6, 6)
    found = [a for a in actors if a.name in pair]
    if not found:
        return img
    cx = float(np.mean([a.x[hit] for a in found]))
    cy = float(np.mean([a.y[hit] for a in found]))
    if not f.inside(cx, cy, pad=-4):
        return img
    px, py = f.px(cx, cy)
    r = max(MARK_MIN_PX, MARK_RADIUS * view.scale)
    f.draw.ellipse([px - r, py - r, px + r, py + r], outline=(*STAGE_FAILED, 255), width=4)
    _label(f, "collision", px - 37, py + r + 3 if py + r + 20 < MAP_H else py - r - 19)
    return img


def render_failure(scenario: Scenario, trace: Trace, case: CaseResult, out_dir: Path, *,
                   policy: str = "policy", options: RenderOptions | None = None) -> Path:
    """Draw a failed test's episode as ``out_dir/failure.gif`` (640x480 px, about
    ``options.fps`` frames per simulated second, played in simulated real time); the frame of
    the collision is always one of them. ConfigError for a trace with nothing to draw."""
    options = options or RenderOptions()
    actors, times, view, bg = scene(scenario, trace, f"test {case.scenario}")
    story = story_of_case(scenario, trace, case, policy)
    steps = media.animation_steps(times, options.animation)
    hit = None
    if case.collision and case.collision_time is not None:
        hit = int(min(np.searchsorted(times, case.collision_time - 1e-9), len(times) - 1))
        steps = sorted({*steps, hit})
    pair = ("ego", case.collision_with or "")

    def frames():
        for i in steps:
            img = frame(bg, view, actors, story, times, i)
            yield (img if hit is None or i < hit
                   else _mark_collision(img, view, actors, i, hit, pair, float(times[hit])))

    out = media.write_gif(Path(out_dir) / FAILURE_GIF, frames(),
                          media.frame_ms(times, steps, options.animation), palette=palette(bg))
    log.info("rendered the failed test %s: %d frames", case_folder(case), len(steps))
    return out
