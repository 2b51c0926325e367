"""The shared media writer: which samples become frames, how long each shows, strips and files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from regen import media
from regen.errors import ConfigError

RED, BLUE = (230, 20, 20), (20, 90, 255)


def _tile(color, size=(40, 30)) -> Image.Image:
    return Image.new("RGB", size, color)


def test_spread_includes_first_and_last_and_never_repeats():
    assert media.spread(101, 5) == [0, 25, 50, 75, 100]
    assert media.spread(3, 16) == [0, 1, 2]  # fewer samples than frames asked for
    assert media.spread(10, 1) == [0]


def test_real_time_steps_follow_fps_and_keep_the_last_sample():
    times = np.arange(0, 4.01, 0.05)  # 81 samples, dt = 0.05 s
    steps = media.animation_steps(times, media.AnimationSettings(fps=10))
    assert steps[:3] == [0, 2, 4] and steps[-1] == 80  # every second sample: 10 per second
    assert media.frame_ms(times, steps, media.AnimationSettings(fps=10)) == 100


def test_real_time_steps_are_capped_and_slow_down_instead():
    times = np.arange(0, 30.01, 0.1)  # 301 samples
    settings = media.AnimationSettings(fps=10, max_frames=60)
    steps = media.animation_steps(times, settings)
    assert len(steps) <= 61 and steps[-1] == 300
    assert media.frame_ms(times, steps, settings) == 600  # 6 samples a frame, still real time


def test_spread_steps_with_a_fixed_frame_time():
    settings = media.AnimationSettings(max_frames=16, fps=None, frame_ms=150)
    steps = media.animation_steps(list(range(200)), settings)
    assert len(steps) == 16 and steps[0] == 0 and steps[-1] == 199
    assert media.frame_ms(list(range(200)), steps, settings) == 150


def test_frame_time_has_a_floor_and_a_single_frame_shows_a_second():
    fast = np.arange(0, 1, 0.001)
    assert media.frame_ms(fast, [0, 1, 2], media.AnimationSettings()) == media.MIN_FRAME_MS
    assert media.frame_ms([0.0], [0], media.AnimationSettings()) == media.SINGLE_FRAME_MS


def test_strip_lays_tiles_side_by_side_with_gaps_and_a_top_band():
    out = media.strip([_tile(RED), _tile(BLUE)], gap_px=4, top_px=10)
    assert out.size == (2 * 40 + 4, 30 + 10)
    px = np.asarray(out)
    assert tuple(px[0, 0]) == media.WHITE  # the band is left for the caller's caption
    assert tuple(px[20, 41]) == media.WHITE  # the gap
    assert tuple(px[20, 5]) == RED and tuple(px[20, 50]) == BLUE


def test_strip_of_nothing_is_a_clear_error():
    with pytest.raises(ConfigError, match="at least one tile"):
        media.strip([])


def test_gif_from_a_generator_with_a_shared_palette_keeps_exact_colors(tmp_path):
    pal = Image.new("P", (1, 1))
    pal.putpalette([*RED, *BLUE, *media.WHITE] + [0] * (768 - 9))
    path = media.write_gif(tmp_path / "sub" / "a.gif", (_tile(c) for c in (RED, BLUE, RED)), 120,
                           palette=pal)
    assert path == tmp_path / "sub" / "a.gif"
    im = Image.open(path)
    assert im.n_frames == 3 and im.info["duration"] == 120 and im.info["loop"] == 0
    colors = []
    for k in range(3):
        im.seek(k)
        colors.append(tuple(np.asarray(im.convert("RGB"))[5, 5]))
    assert colors == [RED, BLUE, RED]
    assert [p.name for p in path.parent.iterdir()] == ["a.gif"]  # no temporary file left


def test_gif_without_frames_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="at least one frame"):
        media.write_gif(tmp_path / "a.gif", [], 100)
    assert not (tmp_path / "a.gif").exists()


def test_png_round_trips(tmp_path):
    img = media.strip([_tile(RED), _tile(BLUE)])
    path = media.write_png(tmp_path / "k.png", img)
    assert np.array_equal(np.asarray(Image.open(path).convert("RGB")), np.asarray(img))
    quick = media.write_png(tmp_path / "q.png", img, compress_level=1)  # faster, the same pixels
    assert np.array_equal(np.asarray(Image.open(quick).convert("RGB")), np.asarray(img))


def test_the_writer_names_no_domain():
    text = Path(media.__file__).read_text().lower()
    assert "driving" not in text and "manipulation" not in text


def test_steps_until_cut_an_animation_at_a_time_and_keep_that_step():
    times = np.round(np.arange(0, 10.01, 0.1), 6)
    steps = list(range(0, 101, 2))
    cut = media.steps_until(times, steps, 4.45)
    assert cut[-1] == 45 and all(i <= 45 for i in cut) and cut[:-1] == list(range(0, 45, 2))
    assert media.steps_until(times, steps, 99.0) == steps  # past the end: all of it


def test_held_shows_the_last_frame_longer():
    assert media.held(3, 100) == [100, 100, media.HOLD_MS]
    assert media.held(1, 5000) == [5000] and media.held(0, 100) == []


def test_a_gif_with_one_duration_per_frame_and_a_shared_palette(tmp_path):
    frames = [_tile(c) for c in (RED, BLUE, RED)]
    path = media.write_gif(tmp_path / "a.gif", frames, media.held(3, 120), palette=media.palette_of(frames))
    im = Image.open(path)
    durations = []
    for k in range(im.n_frames):
        im.seek(k)
        durations.append(im.info["duration"])
        assert tuple(np.asarray(im.convert("RGB"))[5, 5]) == (RED, BLUE, RED)[k]
    assert durations == [120, 120, media.HOLD_MS]


def test_the_caption_band_shows_one_box_per_stage_green_once_reached():
    bar = media.StageBar([(1, 0.5, "a: s0"), (2, None, "b: s1")], "fsm_incomplete", 2, 4.0)
    img = Image.new("RGB", (320, 100), media.WHITE)
    media.draw_caption(img, 44, bar, 4.0)
    px = np.asarray(img).astype(int)
    assert tuple(px[0, 0]) == media.WHITE and tuple(px[44 + 3, 300]) == media.CAPTION_BG
    first, second = px[44 + 31 + 2, 8 + 2], px[44 + 31 + 2, 28 + 2]  # a corner of each box
    assert tuple(first) == media.STAGE_DONE and tuple(second) == media.STAGE_FAILED  # never reached, at the end
    media.draw_caption(img, 44, bar, 0.2)
    assert tuple(np.asarray(img)[44 + 31 + 2, 28 + 2]) == media.STAGE_TODO  # not yet


def test_key_frames_are_the_start_each_stage_reached_and_the_end():
    times = np.round(np.arange(0, 10.01, 0.1), 6)
    picks = media.keyframe_steps(times, [(1, 0.0, "a"), (2, 3.0, "b"), (3, None, "c")], 6)
    assert picks == [(0, "start"), (30, "stage 2 reached"), (65, "during"), (100, "end")]


def _in_palette(img: Image.Image, pal: Image.Image) -> np.ndarray:
    return np.asarray(img.quantize(palette=pal, dither=Image.Dither.NONE).convert("RGB"))


def _decoded(path) -> list[tuple[np.ndarray, int]]:
    im = Image.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append((np.asarray(im.convert("RGB")), im.info["duration"]))
    return out


def test_a_gif_with_a_shared_palette_stores_only_the_box_that_changed(tmp_path):
    """Each frame after the first is stored as the box around what changed over the frame
    before (one colour table for all), and a viewer still sees every frame as drawn."""
    rng = np.random.default_rng(0)
    first = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    second, third = first.copy(), first.copy()
    second[10:14, 20:30] = RED  # a 10 x 4 px change
    third[10:14, 20:30] = RED
    third[50:52, 70:73] = BLUE  # and a second one far from it
    frames = [Image.fromarray(a) for a in (first, second, third)]
    pal = media.palette_of(frames)
    path = media.write_gif(tmp_path / "a.gif", frames, [100, 200, 300], palette=pal)
    shown = _decoded(path)
    for (pixels, ms), img, want in zip(shown, frames, (100, 200, 300), strict=True):
        assert np.array_equal(pixels, _in_palette(img, pal))
        assert ms == want
    im = Image.open(path)
    im.seek(1)
    assert im.dispose_extent == (20, 10, 30, 14)  # (left, top, right, bottom) of the change
    im.seek(2)
    assert im.dispose_extent == (70, 50, 73, 52)


def test_equal_frames_merge_into_a_longer_one_and_a_frame_may_change_everywhere(tmp_path):
    rng = np.random.default_rng(1)
    noise = [Image.fromarray(rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)) for _ in range(2)]
    pal = media.palette_of(noise)  # (nearly) every index used: hardly a spare one for unchanged pixels
    frames = [noise[0], noise[0], noise[1], noise[1], noise[1]]
    shown = _decoded(media.write_gif(tmp_path / "n.gif", frames, [100, 50, 100, 100, 1000], palette=pal))
    assert [ms for _, ms in shown] == [150, 1200]
    for (pixels, _), img in zip(shown, noise, strict=True):
        assert np.array_equal(pixels, _in_palette(img, pal))


def test_the_caption_band_is_the_same_drawn_fresh_or_remembered():
    """The part of the caption that does not change with the time is drawn once and kept: the
    pixels must not depend on whether it was."""
    bar = media.StageBar([(1, 0.5, "a: s0"), (2, 2.0, "b: s1 " * 20)], "fsm_incomplete", None, 4.0)
    pictures = []
    for t in (1.0, 1.0, 3.0):
        if not pictures:
            media._caption_band.cache_clear()
        img = Image.new("RGB", (640, 120), BLUE)
        media.draw_caption(img, 64, bar, t, "ego  5.0 m/s")
        pictures.append(np.asarray(img))
    assert np.array_equal(pictures[0], pictures[1])
    assert not np.array_equal(pictures[1], pictures[2])  # stage 2 reached by t = 3 s
    assert (pictures[0][:64] == BLUE).all()  # nothing above the band


@pytest.mark.parametrize(("mode", "blend"), [("RGB", None), ("RGBA", None), ("RGB", "RGBA"), ("RGBA", "RGBA")])
def test_a_stamped_tag_text_has_the_pixels_of_drawing_it(mode, blend):
    """draw_tag_text (a name tag's text, stamped from its kept glyphs) gives the very pixels of
    ImageDraw.text at a whole pixel, on plain and blending drawings, at the edges too."""
    from PIL import ImageDraw

    rng = np.random.default_rng(7)
    texts = ["ego", "adult1", "traffic_light1 (distracted)", "Wq|gj ÄÖ", "", " ", "10 m"]
    for trial in range(60):
        back = tuple(int(v) for v in rng.integers(0, 256, size=len(mode)))
        drawn, stamped = Image.new(mode, (120, 40), back), Image.new(mode, (120, 40), back)
        font = media.text_font(int(rng.choice([9, 10, 11, 13])), bold=bool(trial % 3 == 0))
        text = texts[trial % len(texts)]
        xy = (int(rng.integers(-12, 110)), int(rng.integers(-12, 36)))
        fill = tuple(int(v) for v in rng.integers(0, 256, size=int(rng.choice([3, 4]))))
        ImageDraw.Draw(drawn, blend).text(xy, text, fill=fill, font=font)
        media.draw_tag_text(ImageDraw.Draw(stamped, blend), xy, text, fill, font)
        assert stamped.tobytes() == drawn.tobytes(), (mode, blend, text, xy, fill)
        if text.strip() and 0 <= xy[0] < 60 and 0 <= xy[1] < 20:  # the text did land on the image
            assert stamped.tobytes() != Image.new(mode, (120, 40), back).tobytes()


def test_a_tag_text_between_pixels_has_the_pixels_pillow_places_there():
    """At a point between pixels Pillow places the glyphs by the fraction: the stamp is drawn at
    the same fraction, so the pixels are ImageDraw.text's; left of or above the image between
    pixels it is drawn as usual."""
    from PIL import ImageDraw

    font = media.text_font(11)
    media._text_stamp.cache_clear()
    points = [(10.5, 4.0), (10.0, 4.25), (3.7, 8.6), (0.015625, 0.5), (60.984375, 2.0), (-3.5, 4.0), (5.0, -2.25)]
    for xy in points:
        drawn, stamped = Image.new("RGB", (80, 30)), Image.new("RGB", (80, 30))
        ImageDraw.Draw(drawn).text(xy, "adult1", fill=(255, 255, 255), font=font)
        media.draw_tag_text(ImageDraw.Draw(stamped), xy, "adult1", (255, 255, 255), font)
        assert stamped.tobytes() == drawn.tobytes(), xy
    assert media._text_stamp.cache_info().currsize == len(points) - 2  # one stamp a fraction


def test_a_line_drawn_word_by_word_has_the_pixels_and_width_of_drawing_it_whole():
    """The caption's time line is stamped word by word (draw_text_line): the same pixels and the
    same width as ImageDraw.text and textlength, at whole and fractional points, in every font
    size the pictures use, with runs of spaces and characters outside ASCII."""
    from PIL import ImageDraw

    rng = np.random.default_rng(11)
    lines = [f"t = {t:5.1f} s / {end:.1f} s   ego {v:4.1f} m/s" for t, end, v in
             zip(rng.uniform(0, 120, 40), rng.choice([8.0, 16.0, 100.0], 40), rng.uniform(0, 30, 40), strict=True)]
    lines += ["  two  spaces ", "Wq|gj ÄÖ AV To", "", "t = 3.0 s   gripper 0.04 m", "ego", "two\nlines here"]
    for k, text in enumerate(lines):
        font = media.text_font(int(rng.choice([10, 11, 13])), bold=bool(k % 2))
        xy = (float(rng.integers(0, 40)) + rng.choice([0.0, 0.25, 0.5, 0.734375]), float(rng.integers(0, 8)))
        drawn, stamped = Image.new("RGB", (420, 30), (28, 30, 36)), Image.new("RGB", (420, 30), (28, 30, 36))
        draw = ImageDraw.Draw(drawn)
        draw.text(xy, text, fill=(240, 240, 240), font=font)
        width = media.draw_text_line(ImageDraw.Draw(stamped), xy, text, (240, 240, 240), font)
        assert stamped.tobytes() == drawn.tobytes(), (text, xy)
        assert width == max(draw.textlength(line, font=font) for line in text.split("\n")), text


def test_a_word_that_kerns_with_a_space_keeps_the_line_whole(monkeypatch):
    """Where a word's end kerns with a space in the font, the words do not simply add up: the
    line is drawn and measured in one go."""
    from PIL import ImageDraw

    font = media.text_font(13, bold=True)
    calls = []
    monkeypatch.setattr(media, "draw_tag_text", lambda *a: calls.append(a))
    monkeypatch.setattr(media, "_kerns_not_with_space", lambda c, f, m: c != "V")
    drawn, whole = Image.new("RGB", (300, 30)), Image.new("RGB", (300, 30))
    ImageDraw.Draw(drawn).text((5, 5), "t = 1.0 s AV", fill=(255, 255, 255), font=font)
    media.draw_text_line(ImageDraw.Draw(whole), (5, 5), "t = 1.0 s AV", (255, 255, 255), font)
    assert not calls and whole.tobytes() == drawn.tobytes()
    media.draw_text_line(ImageDraw.Draw(whole), (5, 5), "t = 1.0 s", (255, 255, 255), font)
    assert len(calls) == 4  # t, =, 1.0, s
