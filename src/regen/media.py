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
from PIL import Image, ImageChops, ImageDraw, ImageFont

from regen.core.io import atomic_write_bytes
from regen.errors import ConfigError

__all__ = ["CAPTION_BG", "CAPTION_FG", "CAPTION_H", "HOLD_MS", "STAGE_DONE", "STAGE_FAILED", "STAGE_TODO",
           "AnimationSettings", "StageBar", "animation_steps", "draw_caption", "draw_tag_text", "draw_text_line", "draw_title",
           "fit_text", "frame_ms", "held", "keyframe_steps", "palette_of", "spread", "steps_until", "strip",
           "text_font", "text_length", "write_gif", "write_png"]

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
    e.g. :func:`held`); returns ``path``. A frame equal to the one before it lengthens that one.

    ``frames`` may be a generator: each frame is converted as it comes, so full-colour frames are
    never all held at once. ``palette`` (a ``P`` image) maps every frame to the same colours
    without dithering, so exact colours stay exact; then only the box where a frame differs
    from the one before is converted and stored (:class:`_GifStream`), which is most of the
    speed of writing an animation whose frames differ in a few places. Without it each frame
    gets its own adaptive palette (Pillow's writer).
    """
    if palette is None:
        return _write_gif_adaptive(path, frames, duration_ms)
    durations = None if isinstance(duration_ms, int) else list(duration_ms)
    stream, prev = None, None
    for k, img in enumerate(frames):
        img = img if img.mode == "RGB" else img.convert("RGB")
        ms = duration_ms if durations is None else durations[k]
        if stream is None:
            full = img.quantize(palette=palette, dither=Image.Dither.NONE)
            stream = _GifStream(img.size, full.getpalette() or [])
            stream.add((0, 0), np.asarray(full), ms)
        else:
            # each pixel maps to its palette entry alone, so converting the box that changed
            # gives the same indices as converting the whole frame
            box = ImageChops.subtract_modulo(img, prev).getbbox(alpha_only=False)
            sub = img.crop(box).quantize(palette=palette, dither=Image.Dither.NONE) if box else None
            stream.add(box[:2] if box else (0, 0), None if sub is None else np.asarray(sub), ms)
        prev = img
    if stream is None:
        raise ConfigError(f"{path}: an animation needs at least one frame")
    return atomic_write_bytes(path, stream.finish())


def _write_gif_adaptive(path: Path, frames: Iterable[Image.Image], duration_ms: int | Sequence[int]) -> Path:
    """:func:`write_gif` without a shared palette: Pillow's writer, an adaptive palette a frame."""
    frames = iter(frames)
    first = next(frames, None)
    if first is None:
        raise ConfigError(f"{path}: an animation needs at least one frame")
    buf = io.BytesIO()
    duration = duration_ms if isinstance(duration_ms, int) else list(duration_ms)
    first.save(buf, format="GIF", save_all=True, append_images=frames, duration=duration,
               loop=0, disposal=1)
    return atomic_write_bytes(path, buf.getvalue())


class _GifStream:
    """A looping GIF89a of palette frames that share one colour table, written as they come.

    Each frame after the first stores only the box around the pixels that changed, with the
    unchanged ones in it transparent (an index no changed pixel uses) and nothing disposed, so
    a viewer composes exactly the frames given; Pillow's writer does the same, but also writes
    a colour table per frame and scans whole frames several times, which cost more than
    drawing them. A frame is held until the next one arrives, since equal frames merge.
    """

    def __init__(self, size: tuple[int, int], palette: Sequence[int]):
        table = bytes(palette[:768]).ljust(768, b"\0")
        self.out = io.BytesIO()
        self.out.write(b"GIF89a" + _u16(size[0]) + _u16(size[1]) + bytes((0xF7, 0, 0)) + table)
        self.out.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + _u16(0) + b"\0")  # loop forever
        self.shown = np.zeros((size[1], size[0]), np.uint8)  # what a viewer shows so far
        self.pending: tuple[int, int, np.ndarray, int | None] | None = None  # left, top, pixels, transparent
        self.ms = 0  # [ms] the pending frame is shown

    def add(self, at: tuple[int, int], pixels: np.ndarray | None, ms: int) -> None:
        """Append a frame shown ``ms`` [ms]: the palette indices ``pixels`` (rows x columns)
        with their top-left corner at ``at`` (left, top) [px] over the frame before, the rest
        as before (None: all of it as before)."""
        if self.pending is None:  # the first frame: all of it
            self.shown[:] = pixels
            self.pending, self.ms = (0, 0, pixels, None), ms
            return
        changed = None
        if pixels is not None:
            left, top = at
            h, w = pixels.shape
            changed = pixels != self.shown[top: top + h, left: left + w]
            rows = np.flatnonzero(changed.any(axis=1))
        if changed is None or rows.size == 0:  # nothing changed: the frame before stays on longer
            self.ms += ms
            return
        cols = np.flatnonzero(changed[rows[0]: rows[-1] + 1].any(axis=0))
        box = np.s_[rows[0]: rows[-1] + 1, cols[0]: cols[-1] + 1]
        sub, moved = pixels[box], changed[box]
        self.shown[top + rows[0]: top + rows[-1] + 1, left + cols[0]: left + cols[-1] + 1] = sub
        free = np.flatnonzero(np.bincount(sub[moved], minlength=256) == 0)
        clear = int(free[-1]) if free.size else None
        if clear is not None:
            sub = np.where(moved, sub, np.uint8(clear))
        self._flush()
        self.pending, self.ms = (left + int(cols[0]), top + int(rows[0]), sub, clear), ms

    def _flush(self) -> None:
        left, top, sub, clear = self.pending
        flags = 1 << 2 | (1 if clear is not None else 0)  # disposal 1: keep; transparency flag
        self.out.write(b"!\xf9\x04" + bytes((flags,)) + _u16(self.ms // 10) + bytes((clear or 0, 0)))
        h, w = sub.shape
        self.out.write(b"," + _u16(left) + _u16(top) + _u16(w) + _u16(h) + b"\0\x08")
        sub = np.ascontiguousarray(sub, dtype=np.uint8)
        self.out.write(Image.frombytes("P", (w, h), sub.tobytes()).tobytes("gif", "P", 8, 0) + b"\0")

    def finish(self) -> bytes:
        """The file's bytes, the last frame written."""
        self._flush()
        return self.out.getvalue() + b";"


def _u16(v: int) -> bytes:
    return int(v).to_bytes(2, "little")


def write_png(path: Path, image: Image.Image, compress_level: int | None = None) -> Path:
    """Write ``image`` as a PNG; returns ``path``. ``compress_level`` is zlib's (0-9); None
    (the default) makes the smallest file, which takes about twice as long as level 6 for some
    5% fewer bytes. The pixels are the same either way."""
    buf = io.BytesIO()
    if compress_level is None:
        image.save(buf, format="PNG", optimize=True)
    else:
        image.save(buf, format="PNG", compress_level=compress_level)
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


@lru_cache(maxsize=4096)
def text_length(text: str, font, mode: str = "RGB") -> float:
    """Width [px] of ``text`` in ``font`` as :meth:`PIL.ImageDraw.ImageDraw.textlength` measures
    it on a drawing of ``mode`` (``draw.mode``); remembered, since frames measure the same tags
    and captions over and over."""
    return ImageDraw.Draw(Image.new(mode, (1, 1))).textlength(text, font=font)


def draw_tag_text(draw: ImageDraw.ImageDraw, xy: tuple[float, float], text: str, fill, font) -> None:
    """``draw.text(xy, text, fill=fill, font=font)``: the same pixels, from a stamp of the glyphs
    kept per text, font and the fraction of a pixel ``xy`` lies at (:func:`_text_stamp`). A name
    tag is drawn on every frame of an animation; rasterizing its glyphs each time took a tenth of
    the time of drawing a road scene's pictures. A drawing whose font mode is not ``L``, or a
    point left or above the image between pixels, draws the text as usual."""
    x, y = xy
    if draw.fontmode != "L" or (x < 0 and x != int(x)) or (y < 0 and y != int(y)):
        draw.text(xy, text, fill=fill, font=font)
        return
    ix, iy = int(x), int(y)
    stamp, (left, top) = _text_stamp(text, font, x - ix, y - iy)
    draw.bitmap((ix + left, iy + top), stamp, fill=fill)


@lru_cache(maxsize=4096)
def _text_stamp(text: str, font, fx: float = 0.0, fy: float = 0.0) -> tuple[Image.Image, tuple[int, int]]:
    """The glyphs of ``text`` drawn at the fraction (``fx``, ``fy``) of a pixel, as a coverage
    mask (``L``: 255 where fully covered), and where its top-left corner lies from the whole
    pixel the text is drawn at [px]. Drawn at a whole pixel plus the same fraction, so Pillow
    places the glyphs as it does on the image; a pixel of margin takes the fraction's shift."""
    left, top, right, bottom = (int(v) for v in font.getbbox(text, "L"))
    ox, oy = 1 + max(0, -left), 1 + max(0, -top)  # the text's point in the stamp, never negative
    stamp = Image.new("L", (max(ox + right + 2, 1), max(oy + bottom + 2, 1)), 0)
    ImageDraw.Draw(stamp).text((ox + fx, oy + fy), text, fill=255, font=font)
    return stamp, (-ox, -oy)


def draw_text_line(draw: ImageDraw.ImageDraw, xy: tuple[float, float], text: str, fill, font) -> float:
    """``draw.text(xy, text, ...)`` for a one-line ``text`` whose words change (a time, a
    speed): each word stamped where Pillow places it (:func:`draw_tag_text`), so a new line
    costs no new rasterizing of the words seen before. Returns the line's width [px], as
    ``draw.textlength`` measures it (text of several lines: drawn in one go, the widest line's
    width)."""
    words, width = _line_layout(text, font, draw.mode)
    _draw_words(draw, xy, text, words, fill, font)
    return width


def _draw_words(draw: ImageDraw.ImageDraw, xy: tuple[float, float], text: str,
                words: list[tuple[float, str]] | None, fill, font) -> None:
    """``text`` drawn as :func:`_line_layout` laid it out (``words``)."""
    if words is None:  # several lines, or a word whose end kerns with a space: drawn in one go
        draw.text(xy, text, fill=fill, font=font)
        return
    for at, word in words:
        draw_tag_text(draw, (xy[0] + at, xy[1]), word, fill, font)


def _line_layout(text: str, font, mode: str) -> tuple[list[tuple[float, str]] | None, float]:
    """Where each word of the one-line ``text`` starts [px from the line's point] and the
    line's width, from the words' kept widths; no words (None) when the end of one kerns with
    a space in ``font``, since then they do not simply add up, or for more than one line."""
    if "\n" in text:  # drawn in one go; as wide as its widest line
        return None, max(text_length(line, font, mode) for line in text.split("\n"))
    words = text.split(" ")
    if not all(_kerns_not_with_space(c, font, mode) for w in words if w for c in {w[0], w[-1]}):
        return None, ImageDraw.Draw(Image.new(mode, (1, 1))).textlength(text, font=font)
    space, at, starts = text_length(" ", font, mode), 0.0, []
    for k, word in enumerate(words):
        at += space if k else 0.0
        if word:
            starts.append((at, word))
            at += text_length(word, font, mode)
    return starts, at


@lru_cache(maxsize=1024)
def _kerns_not_with_space(c: str, font, mode: str) -> bool:
    """Whether ``c`` next to a space, on either side, is as wide as the two apart in ``font``:
    then a line's width is the sum of its words' and spaces', and each word starts there."""
    both = text_length(c, font, mode) + text_length(" ", font, mode)
    return text_length(c + " ", font, mode) == both == text_length(" " + c, font, mode)


def fit_text(draw: ImageDraw.ImageDraw, text: str, font, width: float) -> str:
    """``text`` cut with an ellipsis to ``width`` [px]."""
    return _fit(text, font, width, draw.mode)


@lru_cache(maxsize=1024)
def _fit(text: str, font, width: float, mode: str) -> str:
    if text_length(text, font, mode) <= width:
        return text
    while text and text_length(text + "\u2026", font, mode) > width:
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
    reached on the second.

    Only the time changes from frame to frame: the rest of the band is drawn once per state of
    the stage boxes and kept (:func:`_caption_band`), and the time line is stamped word by word
    (:func:`draw_text_line`), which makes a frame's caption several times cheaper with the same
    pixels.
    """
    draw = ImageDraw.Draw(img)
    big, small = text_font(13, bold=True), text_font(11)
    left = f"t = {t:5.1f} s / {bar.t_end:.1f} s" + (f"   {extra}" if extra else "")
    ok = bar.status == "verified"
    status = bar.status.replace("_", " ")
    if bar.failed_stage is not None and not ok:
        status += f" (stage {bar.failed_stage} unmet)"
    words, width = _line_layout(left, big, draw.mode)  # a new line each frame: stamped by word
    room = img.width - 16 - width - 12
    status = fit_text(draw, status, small, max(room, 40))
    boxes, current = [], None
    at_end = t >= bar.t_end - 1e-9
    for index, reached, _ in bar.stages:
        done = reached is not None and reached <= t + 1e-9
        if done:
            current = (index, reached)
        boxes.append((index, STAGE_DONE if done else (STAGE_FAILED if at_end and index == bar.failed_stage
                                                      else STAGE_TODO)))
    if current is None:
        text = "no stage reached yet" if bar.stages else "no FSM stages"
    else:
        conds = next(c for k, _, c in bar.stages if k == current[0])
        text = f"stage {current[0]}/{len(bar.stages)} at {current[1]:.1f} s: {conds}"
    color = STAGE_DONE if ok else STAGE_FAILED
    apart = room >= 40  # else the verdict is drawn over the end of a long time line, as before
    band = _caption_band(img.mode, img.width, status if apart else "", color, tuple(boxes), text)
    img.paste(band, (0, top))  # cut off at the image's bottom edge
    _draw_words(draw, (8, top + 6), left, words, CAPTION_FG, big)
    if not apart:
        sw = text_length(status, small, draw.mode)
        draw.text((img.width - sw - 8, top + 8), status, fill=color, font=small)


@lru_cache(maxsize=16)  # ~150 kB each; a run shows a few stage states
def _caption_band(mode: str, width: int, status: str, status_color: tuple[int, int, int],
                  boxes: tuple[tuple[int, tuple[int, int, int]], ...], text: str) -> Image.Image:
    """The caption band without its time: the verdict ``status`` (right), the stage boxes
    (index, fill) and ``text`` after them; :data:`CAPTION_H` + 1 rows, as many as the band's
    rectangle covers. Nothing on it overlaps the time, so drawing the time afterwards gives the
    pixels of drawing everything in one go."""
    img = Image.new(mode, (width, CAPTION_H + 1))
    draw = ImageDraw.Draw(img)
    draw.rectangle([0, 0, width, CAPTION_H], fill=CAPTION_BG)
    small = text_font(11)
    y1, y2 = 6, 31
    sw = text_length(status, small, draw.mode)
    draw.text((width - sw - 8, y1 + 2), status, fill=status_color, font=small)
    x = 8
    for index, fill in boxes:
        draw.rectangle([x, y2, x + 16, y2 + 16], fill=fill, outline=(200, 200, 200))
        num = str(index)
        draw.text((x + 8 - text_length(num, small, draw.mode) / 2, y2 + 2), num, fill=WHITE, font=small)
        x += 20
    draw.text((x + 6, y2 + 1), fit_text(draw, text, small, width - x - 14), fill=CAPTION_FG, font=small)
    return img


def draw_title(img: Image.Image, title: str) -> None:
    """A key frame's title ('start', 'stage 2 reached', 'end') in its top-left corner."""
    draw = ImageDraw.Draw(img, "RGBA")
    font = text_font(13, bold=True)
    w = draw.textlength(title, font=font)
    draw.rectangle([0, 0, w + 12, 20], fill=(20, 20, 24, 200))
    draw.text((6, 2), title, fill=WHITE, font=font)
