"""Writing a run's pictures: an animated GIF and a strip of key frames (PNG), atomically.

A domain draws the frames (Pillow images); this module picks which samples of the trace become
frames, how long each is shown, lays tiles side by side and writes the files. Files are written
through :func:`regen.core.io.atomic_write_bytes`, so a crash never leaves half a picture.
"""

from __future__ import annotations

import io
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from regen.core.io import atomic_write_bytes
from regen.errors import ConfigError

__all__ = ["AnimationSettings", "animation_steps", "frame_ms", "spread", "strip", "write_gif",
           "write_png"]

MIN_FRAME_MS = 20  # shortest frame [ms]: viewers play shorter GIF delays slower, not faster
SINGLE_FRAME_MS = 1000  # display time of a one-frame animation [ms]
WHITE = (255, 255, 255)


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


def write_gif(path: Path, frames: Iterable[Image.Image], duration_ms: int,
              palette: Image.Image | None = None) -> Path:
    """Write a looping GIF showing each frame ``duration_ms`` [ms]; returns ``path``.

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
    first.save(buf, format="GIF", save_all=True, append_images=frames, duration=duration_ms,
               loop=0, disposal=1)
    return atomic_write_bytes(path, buf.getvalue())


def write_png(path: Path, image: Image.Image) -> Path:
    """Write ``image`` as an optimized PNG; returns ``path``."""
    buf = io.BytesIO()
    image.save(buf, format="PNG", optimize=True)
    return atomic_write_bytes(path, buf.getvalue())
