"""Pictures of failed behavior tests: the policy's episode as a bird's-eye GIF.

The scenario's own GIF (:mod:`regen.driving.render.scenario`) shows the scripted template ego that
verified; a failed test needs the episode of the policy under test. It is drawn with the same
map, actors, caption and legend, except that the caption tells the test's verdict and the ego's
expected states as the policy reached them, and from the step of a collision on a red ring marks
where it happened. The GIF ends :data:`HOLD_S` after the failure (a collision, or the first
incident of the kind that failed the test) and holds its last frame, so it shows the failure
and not what the simulation did after it. The shared :func:`regen.harness.pictures.keep_failures`
asks for it through the driving harness
(:meth:`regen.driving.testing.harness.DrivingHarness.failure_picture`).
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
from regen.driving.render.legend import legend_entries, legend_image
from regen.driving.render.roads import MAP_H, View
from regen.driving.render.scenario import RenderOptions, scene
from regen.driving.verify.collisions import analyze
from regen.driving.world.setting import DrivingWorld
from regen.harness.pictures import FAILURE_GIF, case_folder

if TYPE_CHECKING:
    from regen.harness.cases import CaseResult

log = logging.getLogger(__name__)

__all__ = ["HOLD_S", "failure_time", "render_failure"]

MARK_RADIUS = 2.5  # [m] of the ring around a collision
MARK_MIN_PX = 12  # [px] the ring stays visible when zoomed out
HOLD_S = 1.0  # [s] of the episode shown after the failure


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


def failure_time(trace: Trace, case: CaseResult) -> float | None:
    """When the test failed [s]: its collision, else the ego's first incident of the kind that
    failed it (a red light, leaving the road); None when it failed over the whole episode (a
    state never reached) or the policy's own failure ended the episode."""
    if case.collision and case.collision_time is not None:
        return float(case.collision_time)
    if not case.cause or case.cause == "state_not_reached" or case.cause.startswith("policy_"):
        return None
    hits = [e.t for e in analyze(trace, ego="ego").events if e.kind == case.cause and "ego" in e.actors]
    return float(min(hits)) if hits else None


def render_failure(scenario: Scenario, trace: Trace, case: CaseResult, out_dir: Path, *,
                   policy: str = "policy", options: RenderOptions | None = None) -> Path:
    """Draw a failed test's episode as ``out_dir/failure.gif`` (640x480 px and the legend band,
    about ``options.fps`` frames per simulated second, played in simulated real time) up to
    :data:`HOLD_S` after the failure (:func:`failure_time`), its last frame held
    :data:`regen.media.HOLD_MS`; the frame of the collision is always one of them. ConfigError
    for a trace with nothing to draw."""
    options = options or RenderOptions()
    actors, times, view, bg = scene(scenario, trace, f"test {case.scenario}")
    story = story_of_case(scenario, trace, case, policy)
    steps = media.animation_steps(times, options.animation)
    hit = None
    if case.collision and case.collision_time is not None:
        hit = int(min(np.searchsorted(times, case.collision_time - 1e-9), len(times) - 1))
        steps = sorted({*steps, hit})
    failed_at = failure_time(trace, case)
    if failed_at is not None:
        steps = media.steps_until(times, steps, failed_at + HOLD_S)
    pair = ("ego", case.collision_with or "")
    legend = legend_image(legend_entries(actors, view, collision=hit is not None))

    def frames():
        for i in steps:
            img = frame(bg, view, actors, story, times, i, legend=legend)
            yield (img if hit is None or i < hit
                   else _mark_collision(img, view, actors, i, hit, pair, float(times[hit])))

    out = media.write_gif(Path(out_dir) / FAILURE_GIF, frames(),
                          media.held(len(steps), media.frame_ms(times, steps, options.animation)),
                          palette=palette(bg))
    log.info("rendered the failed test %s: %d frames up to t = %.1f s", case_folder(case), len(steps),
             float(times[steps[-1]]))
    return out
