"""Pictures of a driving run: a bird's-eye GIF and a strip of key frames (PNG).

The road is drawn once from the OpenDRIVE map into a background image
(:mod:`regen.driving.render.roads`); each frame then crops that background and draws only the
actors (:mod:`regen.driving.render.actors`) and a caption (:mod:`regen.driving.render.frames`)
with Pillow, which keeps drawing far cheaper than the simulation it shows. The files are written
by the shared media writer (:mod:`regen.media`), which stores of each GIF frame only what
changed since the one before.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from regen import media
from regen.contract import ANIMATION, KEYFRAMES
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.driving.render.actors import actors_from_trace
from regen.driving.render.frames import Frames, choose_view, keyframe_steps, palette, story_of
from regen.driving.render.legend import legend_entries, legend_image
from regen.driving.render.roads import background, map_layers
from regen.errors import ConfigError

log = logging.getLogger(__name__)

__all__ = ["render_scenario", "RenderOptions"]

ANIMATION_FILE = "bird_eye.gif"
KEYFRAMES_FILE = "keyframes.png"
MAX_FRAMES = 200  # more frames than this only make the GIF bigger, not clearer
KEYFRAME_GAP = 4  # [px] between tiles of the key-frame strip
KEYFRAMES_ZLIB = 6  # zlib level of the strip: ~20 ms less a run than the smallest file, ~5% bigger


@dataclass(frozen=True)
class RenderOptions:
    """Knobs of the pictures; the defaults give a ~640x480 GIF at 10 frames per simulated second."""

    fps: float = 10.0  # frames per simulated second [1/s]
    max_frames: int = MAX_FRAMES
    keyframes: int = 6  # at most this many tiles in the strip (at least 4 when the trace allows)

    @property
    def animation(self) -> media.AnimationSettings:
        """The GIF's frame picks: played in simulated real time."""
        return media.AnimationSettings(max_frames=self.max_frames, fps=self.fps)


def scene(scenario: Scenario, trace: Trace, what: str):
    """What every picture of a trace is drawn from: (actors, times [s], view, background).
    ConfigError naming ``what`` for a trace without steps or drawable actors."""
    if trace.steps == 0:
        raise ConfigError(f"{what}: the trace has no steps; nothing to draw")
    actors = actors_from_trace(trace)
    if not actors:
        raise ConfigError(f"{what}: the trace has no drawable actors")
    view = choose_view(actors)
    return actors, np.asarray(trace.times, float), view, background(map_layers(scenario, trace), view)


def with_camera(scenario: Scenario, trace: Trace, tiles: list, times: list[float]) -> list:
    """Each bird's-eye tile with the ego's forward camera view at the same time below it
    (:mod:`regen.driving.render.camera`, 16:9 at the tile's width); the tiles as they are, with
    a warning, where the camera is not installed or fails (the bird's-eye picture is never lost)."""
    from PIL import Image

    from regen.driving.render.camera import camera_available, camera_frames

    if not tiles or not camera_available():
        return tiles
    width = tiles[0].width
    try:
        shots = camera_frames(scenario, trace, times, size=(width, round(width * 9 / 16)))
    except Exception as exc:  # noqa: BLE001 - any renderer failure costs the camera row only
        log.warning("scenario %s: key frames drawn without the camera view (%s: %s)", scenario.id,
                    type(exc).__name__, exc)
        return tiles
    out = []
    for tile, shot in zip(tiles, shots, strict=True):
        both = Image.new("RGB", (width, tile.height + shot.height), (255, 255, 255))
        both.paste(tile, (0, 0))
        both.paste(shot, (0, tile.height))
        out.append(both)
    return out


def render_scenario(scenario: Scenario, trace: Trace, verdict: Verdict, out_dir: Path,
                    options: RenderOptions | None = None) -> dict[str, Path]:
    """Draw a driving run: ``bird_eye.gif`` and ``keyframes.png`` in ``out_dir``.

    The GIF plays in simulated real time at about ``options.fps`` frames per simulated second
    (at most ``options.max_frames`` frames; the last one held :data:`regen.media.HOLD_MS`) at
    640x480 px plus the legend band below (:mod:`regen.driving.render.legend`); the strip shows
    4-6 frames of 640x480 px side by side (start, each FSM stage reached, end) separated by 4 px,
    each with the ego's forward camera view below it where Panda3D is installed (the ``camera``
    extra; :func:`with_camera`).
    Returns ``{ANIMATION: gif path, KEYFRAMES: png path}`` (roles of :mod:`regen.domains`).
    A trace without steps or actors raises :class:`ConfigError`; a map that cannot be read is
    drawn as plain ground with a warning.
    """
    options = options or RenderOptions()
    out_dir = Path(out_dir)
    actors, times, view, bg = scene(scenario, trace, f"scenario {scenario.id!r}")
    story = story_of(scenario, trace, verdict)

    steps = media.animation_steps(times, options.animation)
    legend = legend_image(legend_entries(actors, view))
    animation = Frames(bg, view, actors, story, times, legend)
    gif = media.write_gif(out_dir / ANIMATION_FILE, (animation.draw(i) for i in steps),
                          media.held(len(steps), media.frame_ms(times, steps, options.animation)),
                          palette=palette(bg))

    picks = keyframe_steps(times, story, max(1, options.keyframes))
    still = Frames(bg, view, actors, story, times)  # key frames carry no legend
    tiles = with_camera(scenario, trace, [still.draw(i, title=title) for i, title in picks],
                        [float(times[i]) for i, _ in picks])
    png = media.write_png(out_dir / KEYFRAMES_FILE, media.strip(tiles, gap_px=KEYFRAME_GAP),
                          compress_level=KEYFRAMES_ZLIB)
    log.info("rendered %s: %d GIF frames (%.0f kB), %d key frames", scenario.id, len(steps),
             gif.stat().st_size / 1024, len(tiles))
    return {ANIMATION: gif, KEYFRAMES: png}
