"""Writing a run's pictures: an animated GIF and a strip of key frames (PNG), atomically.

A domain draws the frames (Pillow images); this module picks which samples of the trace become
frames, how long each is shown, lays tiles side by side and writes the files. Files are written
through :func:`regen.core.io.atomic_write_bytes`, so a crash never leaves half a picture.

What the domains' frames have in common is drawn here too: the caption band under a frame (the
time, the verdict and one box per FSM stage, :func:`draw_caption`), a key frame's title
(:func:`draw_title`) and the font, so the pictures of every domain read alike.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from regen.core.io import atomic_write_bytes
from regen.errors import ConfigError

__all__ = ["CAPTION_BG", "CAPTION_FG", "CAPTION_H", "HOLD_MS", "STAGE_DONE", "STAGE_FAILED", "STAGE_TODO",
           "AnimationSettings", "StageBar", "animation_steps", "draw_caption", "draw_title", "fit_text",
           "frame_ms", "held", "keyframe_steps", "palette_of", "spread", "steps_until", "strip", "text_font", "write_gif", "write_png"]

MIN_FRAME_MS = 20  # shortest frame [ms]: viewers play shorter GIF delays slower, not faster
SINGLE_FRAME_MS = 1000  # display time of a one-frame animation [ms]
HOLD_MS = 1500  # [ms] the last frame of an animation stays this long before it loops
WHITE = (255, 255, 255)

# The caption band under a frame (colors RGB).
CAPTION_H = 56  # [px]
CAPTION_BG = (28, 30, 36)
CAPTION_FG = (240, 240, 240)
STAGE_DONE = (0, 190, 90)
STAGE_TODO = (90, 92, 100)
STAGE_FAILED = (220, 50, 50)


@dataclass(frozen=True)
class AnimationSettings:
    """Which trace samples become animation frames, and how long each is shown.

    With ``fps`` set, frames are about ``fps`` per simulated second and play in simulated real
    time; with ``fps=None``, ``max_frames`` samples are spread evenly from the first to the last.
    """

    max_frames: int = 200  # at most this many frames (the last sample is always one more)
    fps: float | None = 10.0  # frames per simulated second [1/s]; None: spread max_frames evenly
    frame_ms: int | None = None  # display time of each frame [ms]; None: simulated real time


def spread(n: int, count: int) -> list[int]:
    """``count`` sample indices spread evenly over ``0 .. n-1``, first and last included."""
    return sorted({int(round(k * (n - 1) / max(1, count - 1))) for k in range(count)})


def animation_steps(times: Sequence[float], settings: AnimationSettings) -> list[int]:
    """Indices into ``times`` [s] of the animation's frames, in order, last sample included."""
    n = len(times)
    if settings.fps is None:
        return spread(n, settings.max_frames)
    diffs = np.diff(np.asarray(times, float))
    dt = float(np.median(diffs)) if n > 1 else 1.0  # [s] per sample
    stride = max(1, int(round(1.0 / (settings.fps * dt)))) if dt > 0 else 1
    stride = max(stride, -(-n // settings.max_frames))
    steps = list(range(0, n, stride))
    if steps[-1] != n - 1:
        steps.append(n - 1)
    return steps


def steps_until(times: Sequence[float], steps: Sequence[int], end: float) -> list[int]:
    """The ``steps`` whose time [s] is at most ``end``, and the first sample at or after ``end``
    (so an animation cut at a failure shows the failure's own step, and never is empty)."""
    t = np.asarray(times, float)
    last = int(min(np.searchsorted(t, end - 1e-9), len(t) - 1))
    return sorted({*(i for i in steps if i <= last), last})


def held(count: int, duration_ms: int, hold_ms: int = HOLD_MS) -> list[int]:
    """Display times [ms] of ``count`` frames: ``duration_ms`` each, the last one ``hold_ms``
    (at least ``duration_ms``), so a viewer sees the end before the animation loops."""
    if count <= 0:
        return []
    return [duration_ms] * (count - 1) + [max(duration_ms, hold_ms)]


def keyframe_steps(times: Sequence[float], stages: Sequence[tuple[int, float | None, str]],
                   count: int) -> list[tuple[int, str]]:
    """(index, title) of a strip's key frames: the start, the step where each FSM stage
    (index, reached_at [s] or None, ...) was reached and the end; at least 4 (the widest gaps
    filled) and at most ``count``, evenly spread stages kept when there are too many."""
    times = np.asarray(times, float)
    n = len(times)
    picks: dict[int, str] = {0: "start"}
    reached = [(k, r) for k, r, _ in stages if r is not None]
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


def frame_ms(times: Sequence[float], steps: Sequence[int], settings: AnimationSettings) -> int:
    """Display time [ms] of each frame: the fixed one, else the simulated time between frames."""
    if settings.frame_ms is not None:
        return settings.frame_ms
    if len(steps) < 2:
        return SINGLE_FRAME_MS
    gaps = np.diff(np.asarray(times, float)[list(steps)])
    return max(MIN_FRAME_MS, int(round(1000 * float(np.median(gaps)))))


def strip(tiles: Sequence[Image.Image], *, gap_px: int = 0, top_px: int = 0,
          background: tuple[int, int, int] = WHITE) -> Image.Image:
    """The tiles side by side, ``gap_px`` [px] apart, below a free band ``top_px`` [px] high
    (for a caption the caller draws); tiles are as high as the first."""
    if not tiles:
        raise ConfigError("a strip of key frames needs at least one tile")
    width = sum(t.width for t in tiles) + gap_px * max(0, len(tiles) - 1)
    out = Image.new("RGB", (width, tiles[0].height + top_px), background)
    x = 0
    for tile in tiles:
        out.paste(tile, (x, top_px))
        x += tile.width + gap_px
    return out


def palette_of(images: Sequence[Image.Image], colors: int = 256) -> Image.Image:
    """One GIF palette (a ``P`` image) for frames like ``images`` (e.g. the first, a middle and
    the last frame of an animation), for :func:`write_gif`: quantizing each frame to it is far
    cheaper than an adaptive palette per frame, and colours do not flicker between frames."""
    if not images:
        raise ConfigError("a palette needs at least one image")
    sheet = strip([im.convert("RGB") for im in images])
    return sheet.quantize(colors, method=Image.Quantize.FASTOCTREE)


def write_gif(path: Path, frames: Iterable[Image.Image], duration_ms: int | Sequence[int],
              palette: Image.Image | None = None) -> Path:
    """Write a looping GIF showing each frame ``duration_ms`` [ms] (one number, or one per frame,
    e.g. :func:`held`); returns ``path``.

    ``frames`` may be a generator: each frame is converted as it comes, so full-colour frames are
    never all held at once. ``palette`` (a ``P`` image) maps every frame to the same colours
    without dithering, so exact colours stay exact; without it each frame gets its own adaptive
    palette.
    """
    if palette is not None:
        frames = (f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames)
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise ConfigError(f"{path}: an animation needs at least one frame")
    buf = io.BytesIO()
    duration = duration_ms if isinstance(duration_ms, int) else list(duration_ms)
    first.save(buf, format="GIF", save_all=True, append_images=frames, duration=duration,
               loop=0, disposal=1)
    return atomic_write_bytes(path, buf.getvalue())


def write_png(path: Path, image: Image.Image) -> Path:
    """Write ``image`` as an optimized PNG; returns ``path``."""
    buf = io.BytesIO()
    image.save(buf, format="PNG", optimize=True)
    return atomic_write_bytes(path, buf.getvalue())


# --- what the domains' frames have in common ---------------------------------------------------

@lru_cache(maxsize=16)
def text_font(size: int, bold: bool = False):
    """DejaVu Sans from matplotlib's own data (always installed with it), else Pillow's default."""
    try:
        import matplotlib

        name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
        return ImageFont.truetype(str(Path(matplotlib.get_data_path()) / "fonts" / "ttf" / name), size)
    except OSError:
        return ImageFont.load_default(size=size)


def fit_text(draw: ImageDraw.ImageDraw, text: str, font, width: float) -> str:
    """``text`` cut with an ellipsis to ``width`` [px]."""
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "\u2026", font=font) > width:
        text = text[:-1]
    return text + "\u2026"


@dataclass(frozen=True)
class StageBar:
    """What a frame's caption band tells: the FSM stages and the verdict."""

    stages: list[tuple[int, float | None, str]]  # index, reached_at [s] (None: never), 'actor: state, ...'
    status: str  # the verdict's status ('verified' shows green, anything else red)
    failed_stage: int | None  # the stage that was never reached (red at the end)
    t_end: float  # [s] the last sample's time


def draw_caption(img: Image.Image, top: int, bar: StageBar, t: float, extra: str = "") -> None:
    """The caption band, :data:`CAPTION_H` high from ``top`` [px]: the time ``t`` [s] (and
    ``extra``, e.g. the ego's speed) and the verdict on the first line; one box per FSM stage
    (green once reached, red for the stage never reached, from the end on) and the last stage
    reached on the second."""
    draw = ImageDraw.Draw(img)
    width = img.width
    draw.rectangle([0, top, width, top + CAPTION_H], fill=CAPTION_BG)
    big, small = text_font(13, bold=True), text_font(11)
    y1, y2 = top + 6, top + 31
    left = f"t = {t:5.1f} s / {bar.t_end:.1f} s" + (f"   {extra}" if extra else "")
    draw.text((8, y1), left, fill=CAPTION_FG, font=big)
    ok = bar.status == "verified"
    status = bar.status.replace("_", " ")
    if bar.failed_stage is not None and not ok:
        status += f" (stage {bar.failed_stage} unmet)"
    room = width - 16 - draw.textlength(left, font=big) - 12
    status = fit_text(draw, status, small, max(room, 40))
    sw = draw.textlength(status, font=small)
    draw.text((width - sw - 8, y1 + 2), status, fill=STAGE_DONE if ok else STAGE_FAILED, font=small)
    x = 8
    current = None
    at_end = t >= bar.t_end - 1e-9
    for index, reached, _ in bar.stages:
        done = reached is not None and reached <= t + 1e-9
        if done:
            current = (index, reached)
        fill = STAGE_DONE if done else (STAGE_FAILED if at_end and index == bar.failed_stage
                                        else STAGE_TODO)
        draw.rectangle([x, y2, x + 16, y2 + 16], fill=fill, outline=(200, 200, 200))
        num = str(index)
        draw.text((x + 8 - draw.textlength(num, font=small) / 2, y2 + 2), num, fill=WHITE, font=small)
        x += 20
    if current is None:
        text = "no stage reached yet" if bar.stages else "no FSM stages"
    else:
        conds = next(c for k, _, c in bar.stages if k == current[0])
        text = f"stage {current[0]}/{len(bar.stages)} at {current[1]:.1f} s: {conds}"
    draw.text((x + 6, y2 + 1), fit_text(draw, text, small, width - x - 14), fill=CAPTION_FG, font=small)


def draw_title(img: Image.Image, title: str) -> None:
    """A key frame's title ('start', 'stage 2 reached', 'end') in its top-left corner."""
    draw = ImageDraw.Draw(img, "RGBA")
    font = text_font(13, bold=True)
    w = draw.textlength(title, font=font)
    draw.rectangle([0, 0, w + 12, 20], fill=(20, 20, 24, 200))
    draw.text((6, 2), title, fill=WHITE, font=font)
