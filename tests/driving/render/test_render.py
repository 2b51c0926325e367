"""Bird's-eye GIF and key-frame strip of driving runs, drawn over a real generated map."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("scenic")
pytest.importorskip("scenariogeneration")

from regen.contract import ANIMATION, KEYFRAMES  # noqa: E402
from regen.core.behavior import Behavior  # noqa: E402
from regen.core.scenario import (  # noqa: E402
    FSM,
    AbstractState,
    Entity,
    PredicateCall,
    Scenario,
    Stage,
    StateRef,
)
from regen.core.trace import ActorTrack, Trace  # noqa: E402
from regen.core.verdict import StageResult, Verdict  # noqa: E402
from regen.driving.render import roads as render_map
from regen.driving.render import scenario as render  # noqa: E402
from regen.driving.render.actors import BRAKE, EGO, LIGHT_COLORS, PARKED, actors_from_trace  # noqa: E402
from regen.driving.render.frames import choose_view  # noqa: E402
from regen.driving.render.legend import WORDS, legend_entries, legend_image  # noqa: E402
from regen.errors import ConfigError  # noqa: E402
from regen.media import HOLD_MS  # noqa: E402

DT = 0.1  # [s]

def _camera() -> bool:
    from regen.driving.render.camera import camera_available

    return camera_available()


#: a key frame's height [px]: the 640x480 bird's-eye view, and the 640x360 forward camera below it
#: where Panda3D is installed
KEY_H = 480 + (360 if _camera() else 0)


def _scenario(actors: dict[str, str], stages: int) -> Scenario:
    names = list(actors)
    states = [AbstractState(name=f"s{k}", actor=names[k % len(names)],
                            all_of=[PredicateCall(name="moving", args=[names[k % len(names)]])])
              for k in range(stages)]
    return Scenario(
        id="demo", domain="driving",
        behavior=Behavior(text="the ego-vehicle stops abruptly", domain="driving"),
        causal_graph=["cause", "the ego-vehicle stops abruptly"], narrative="test",
        entities=[Entity(name=n, asset=a, kind="ego" if n == "ego" else "agent") for n, a in actors.items()],
        fsm=FSM(states=states, stages=[Stage(conditions=[StateRef(actor=s.actor, state=s.name)])
                                       for s in states]),
    )


def _verdict(reached: list[float | None], unmet: int | None = None) -> Verdict:
    return Verdict(feasible=unmet is None, status="verified" if unmet is None else "fsm_incomplete",
                   reason="test", first_unmet_stage=unmet,
                   stages=[StageResult(index=k + 1, conditions=[f"a: s{k}"], reached_at=r)
                           for k, r in enumerate(reached)])


def _run(map_path, seconds: float = 4.0, map_name: str = "straight"):
    """Ego east-bound at 5 m/s from x=-20; a sedan ahead; an ambulance with its siren behind;
    a traffic light turning red -> green; the ego brakes for the second half."""
    t = np.round(np.arange(0, seconds + 1e-9, DT), 6)
    n = len(t)
    half = t >= seconds / 2
    actors = {
        "ego": ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, x=list(-20 + 5 * t),
                          y=[-1.75] * n, heading=[0.0] * n, speed=[5.0] * n,
                          states={"brake_lights": ["on" if h else "off" for h in half]}),
        "car1": ActorTrack(asset="sedan", length=4.6, width=1.9, x=list(5 + 4 * t), y=[-1.75] * n,
                           heading=[0.0] * n),
        "ambulance1": ActorTrack(asset="ambulance", length=6.4, width=2.4, x=list(-32 + 6 * t),
                                 y=[-5.25] * n, states={"siren": ["on"] * n}),
        "light1": ActorTrack(asset="traffic_light", kind="object", x=[8.0] * n, y=[-9.0] * n,
                             states={"light_state": ["green" if h else "red" for h in half]}),
        "parked1": ActorTrack(asset="parked_car", kind="object", x=[22.0] * n, y=[-8.5] * n,
                              heading=[0.0] * n, states={"door": ["open" if h else "closed" for h in half]}),
    }
    trace = Trace(dt=DT, times=list(t), actors=actors,
                  meta={"map": map_name, "map_path": str(map_path)})
    scenario = _scenario({"ego": "sedan", "car1": "sedan", "ambulance1": "ambulance",
                          "light1": "traffic_light", "parked1": "parked_car"}, 3)
    return scenario, trace


def _frames(path) -> list[np.ndarray]:
    im = Image.open(path)
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(np.asarray(im.convert("RGB")).astype(int))
    return out


def _mask(img: np.ndarray, color, tol: int = 12) -> np.ndarray:
    return (np.abs(img - np.asarray(color)).sum(axis=2) <= tol)


@pytest.fixture(scope="module")
def rendered(straight_map, tmp_path_factory):
    scenario, trace = _run(straight_map)
    out = render.render_scenario(scenario, trace, _verdict([0.0, 1.5, 2.5]),
                                 tmp_path_factory.mktemp("run"))
    return scenario, trace, out


def test_returns_the_shared_roles_under_the_domains_file_names(rendered):
    _, _, out = rendered
    assert set(out) == {ANIMATION, KEYFRAMES}
    assert (out[ANIMATION].name, out[KEYFRAMES].name) == ("bird_eye.gif", "keyframes.png")


def test_gif_has_one_frame_per_tenth_of_a_second_at_640x480(rendered):
    _, trace, out = rendered
    im = Image.open(out[ANIMATION])
    legend = legend_image(legend_entries(actors_from_trace(trace), choose_view(actors_from_trace(trace))))
    assert im.size == (640, 480 + legend.height)  # the frame, and the legend band below it
    assert im.n_frames == trace.steps  # dt = 0.1 s at 10 fps: every step is a frame
    assert im.info["duration"] == 100  # [ms]: plays in simulated real time
    im.seek(im.n_frames - 1)
    assert im.info["duration"] == HOLD_MS  # the end stays a moment before the loop starts over
    assert out[ANIMATION].stat().st_size < 2 * 1024 * 1024


def test_a_legend_under_the_animation_names_what_the_run_shows(rendered):
    _, trace, out = rendered
    actors = actors_from_trace(trace)
    entries = legend_entries(actors, choose_view(actors))
    # the ego, a sedan, an ambulance with its siren on, a light, a parked car whose door opens,
    # the ego's brake lights
    assert {"ego", "path", "vehicle", "emergency", "parked", "door", "traffic_light", "brake", "tag",
            "stages"} <= set(entries)
    assert not {"pedestrian", "hazard", "gnss", "distracted", "collision"} & set(entries)
    assert "halo" in WORDS["ego"] and "path" in WORDS["path"]
    band = _frames(out[ANIMATION])[0][480:]
    assert band.shape[0] >= 2 * 16  # two rows of entries at least
    assert _mask(band, EGO, 0).sum() > 50  # the ego's swatch is drawn in the ego's colour
    assert _mask(band, LIGHT_COLORS["red"], 0).sum() > 10
    assert Image.open(out[KEYFRAMES]).size[1] == KEY_H  # the key frames carry no legend


def test_name_tags_never_cover_each_other_and_keep_off_other_actors():
    from regen.driving.render.actors import Canvas
    from regen.driving.render.roads import View

    view = View(scale=10.0, x0=0.0, y1=42.4, width=640, height=424, follow=None)
    img = Image.new("RGB", (640, 424))
    f = Canvas(img, view, 0, 0)
    cx, cy = f.px(32.0, 21.2)  # the middle of the window
    other = (cx - 30, cy - 40, cx + 30, cy - 12)  # an actor's body right above the spot
    f.bodies.append(other)
    own = (cx - 10, cy - 10, cx + 10, cy + 10)
    for k in range(7):  # seven actors at one spot: each tag must find a place of its own
        f.label(f"pedestrian{k}", 32.0, 21.2, own, (255, 140, 0))
    for a, rect in enumerate(f.labels):
        assert not (rect[0] < other[2] and other[0] < rect[2] and rect[1] < other[3] and other[1] < rect[3]), rect
        for b in f.labels[a + 1:]:
            assert not (rect[0] < b[2] and b[0] < rect[2] and rect[1] < b[3] and b[1] < rect[3]), (rect, b)


def test_ego_is_drawn_where_the_trace_puts_it(rendered):
    scenario, trace, out = rendered
    frames = _frames(out[ANIMATION])
    view = choose_view(actors_from_trace(trace))
    assert view.follow is None  # the actors fit one fixed view here
    ego = trace.actors["ego"]
    centroids = []
    reach = int(0.5 * ego.length * view.scale) + 6  # [px] half the car and a little
    for k in (0, len(frames) - 1):
        px, py = view.to_px(ego.x[k], ego.y[k])
        r0, c0 = int(py) - reach, int(px) - reach
        near = _mask(frames[k][r0: r0 + 2 * reach, c0: c0 + 2 * reach], EGO)
        rows, cols = np.nonzero(near)
        # a 4.6 m x 1.9 m body at ~14 px/m, minus the windscreen band
        assert len(rows) > 0.6 * ego.length * ego.width * view.scale**2, "the ego is not there"
        centroids.append((c0 + cols.mean(), r0 + rows.mean()))
        assert abs(centroids[-1][0] - px) < 4 and abs(centroids[-1][1] - py) < 3
    # it moved right by the distance driven, at the view's scale
    moved = centroids[1][0] - centroids[0][0]
    assert moved == pytest.approx((ego.x[-1] - ego.x[0]) * view.scale, abs=4)
    assert abs(centroids[1][1] - centroids[0][1]) < 2


def test_the_road_is_drawn_from_the_map(rendered):
    _, trace, out = rendered
    first = _frames(out[ANIMATION])[0][: render_map.MAP_H]
    view = choose_view(actors_from_trace(trace))
    # the map's sidewalks sit 7-9 m off the centre line; grass beyond 9 m
    for y, color in ((8.0, render_map.SIDEWALK), (12.0, render_map.GRASS)):
        px, py = view.to_px(-40.0 + 0 * y, y)
        row, col = int(py), int(max(px, 5))
        assert _mask(first[row - 1: row + 2, col: col + 3], color, tol=20).all(), (y, color)
    # the yellow centre line at y = 0 spans the window
    _, py0 = view.to_px(0.0, 0.0)
    band = first[int(py0) - 2: int(py0) + 3]
    assert _mask(band, render_map.MARK_YELLOW, tol=60).any(axis=0).mean() > 0.8


def test_light_states_and_brake_lights_follow_the_trace(rendered):
    _, trace, out = rendered
    frames = _frames(out[ANIMATION])
    view = choose_view(actors_from_trace(trace))
    lx, ly = view.to_px(8.0, -9.0)  # the light's position
    first, last = (f[int(ly) - 15: int(ly) + 15, int(lx) - 15: int(lx) + 15] for f in frames[::len(frames) - 1])
    red, green = LIGHT_COLORS["red"], LIGHT_COLORS["green"]
    assert _mask(first, red, 6).sum() > 20 and _mask(first, green, 6).sum() == 0
    assert _mask(last, green, 6).sum() > 20 and _mask(last, red, 6).sum() == 0
    whole_first, whole_last = frames[0][: render_map.MAP_H], frames[-1][: render_map.MAP_H]
    assert _mask(whole_first, BRAKE, 0).sum() == 0
    assert _mask(whole_last, BRAKE, 0).sum() > 4


def test_parked_car_is_a_car_whose_door_opens(rendered):
    _, trace, out = rendered
    frames = _frames(out[ANIMATION])
    view = choose_view(actors_from_trace(trace))
    px, py = view.to_px(22.0, -8.5)
    first, last = (f[int(py) - 40: int(py) + 40, int(px) - 50: int(px) + 50] for f in frames[::len(frames) - 1])
    assert _mask(first, PARKED, 0).sum() > 0.6 * 4.6 * 1.9 * view.scale**2
    door = (255, 230, 0)
    assert _mask(first, door, 0).sum() == 0 and _mask(last, door, 0).sum() > 10


def test_siren_glow_appears_around_the_ambulance(rendered):
    _, trace, out = rendered
    first = _frames(out[ANIMATION])[0]
    view = choose_view(actors_from_trace(trace))
    px, py = view.to_px(trace.actors["ambulance1"].x[0], trace.actors["ambulance1"].y[0])
    patch = first[int(py) - 40: int(py) + 40, max(int(px) - 60, 0): int(px) + 60]
    reds = (patch[..., 0] - patch[..., 2] > 60).sum()
    blues = (patch[..., 2] - patch[..., 0] > 60).sum()
    assert reds + blues > 100


def test_keyframe_strip_has_start_each_stage_and_end(rendered):
    _, _, out = rendered
    strip = Image.open(out[KEYFRAMES])
    # stage 1 at t=0 shares the start tile: start, stage 2, stage 3, end
    assert strip.size == (4 * 640 + 3 * render.KEYFRAME_GAP, KEY_H)


def test_many_stages_are_capped_at_six_tiles_and_few_filled_to_four(straight_map, tmp_path):
    scenario, trace = _run(straight_map)
    many = render.render_scenario(scenario, trace, _verdict([0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]),
                                  tmp_path / "many")
    assert Image.open(many[KEYFRAMES]).size[0] == 6 * 640 + 5 * render.KEYFRAME_GAP
    none = render.render_scenario(scenario, trace, _verdict([None, None, None], unmet=1),
                                  tmp_path / "none")
    assert Image.open(none[KEYFRAMES]).size[0] == 4 * 640 + 3 * render.KEYFRAME_GAP


def test_long_runs_follow_the_ego_and_cap_frames(straight_map, tmp_path):
    scenario, trace = _run(straight_map, seconds=30.0)  # ego drives 150 m: too far for one view
    out = render.render_scenario(scenario, trace, _verdict([0.0, 10.0, 20.0]), tmp_path,
                                 render.RenderOptions(fps=10, max_frames=60))
    im = Image.open(out[ANIMATION])
    assert im.n_frames <= 61
    view = choose_view(actors_from_trace(trace))
    assert view.follow == "ego"
    frames = _frames(out[ANIMATION])
    for k in (0, len(frames) - 1):  # the ego stays near the middle of the window
        band = frames[k][180:240]  # the ego's lane (y = -1.75 m) crosses the window here
        rows, cols = np.nonzero(_mask(band, EGO))
        assert len(cols) > 100 and abs(np.median(cols) - 320) < 40


def test_missing_map_draws_plain_ground(straight_map, tmp_path, caplog):
    scenario, trace = _run(straight_map)
    trace.meta["map_path"] = str(tmp_path / "gone.xodr")
    trace.meta["map"] = "no_such_map"
    out = render.render_scenario(scenario, trace, _verdict([0.0, 1.0, 2.0]), tmp_path)
    first = _frames(out[ANIMATION])[0][: render_map.MAP_H]
    assert _mask(first, render_map.ROAD, 6).sum() < 50  # no road drawn (a map has ~100k such px)
    assert _mask(first, EGO).sum() > 50  # actors still are
    assert "gone.xodr" in caplog.text


def test_empty_trace_is_a_clear_error(tmp_path):
    scenario = _scenario({"ego": "sedan"}, 1)
    with pytest.raises(ConfigError, match="no steps"):
        render.render_scenario(scenario, Trace(dt=DT, times=[], actors={}), _verdict([None]), tmp_path)


def test_a_queue_is_drawn_as_its_cars_one_behind_the_other(straight_map, tmp_path):
    from scipy import ndimage

    from regen.driving.render.actors import VEHICLE

    scenario, trace = _run(straight_map, seconds=1.0)
    n = len(trace.times)
    trace.actors = {"ego": trace.actors["ego"],
                    "traffic_queue1": ActorTrack(asset="traffic_queue", length=15.5, width=1.9, x=[10.0] * n,
                                                 y=[-1.75] * n, heading=[0.0] * n)}
    scenario = _scenario({"ego": "sedan", "traffic_queue1": "traffic_queue"}, 2)
    out = render.render_scenario(scenario, trace, _verdict([0.0, 0.5]), tmp_path)
    frame = _frames(out[ANIMATION])[0]
    view = choose_view(actors_from_trace(trace))
    (x0, y0), (x1, _) = view.to_px(10.0 - 8.0, -1.75), view.to_px(10.0 + 8.0, -1.75)
    window = frame[int(y0) - 6: int(y0) + 6, int(min(x0, x1)): int(max(x0, x1))]
    assert _mask(window, VEHICLE, 0).sum() > 0
    _, screens = ndimage.label(_mask(window, (30, 36, 48), 0).any(axis=0))  # one windscreen per car
    assert screens == 3


def test_the_gif_shows_exactly_the_drawn_frames_and_the_cars_move_in_it(straight_map, tmp_path):
    """The GIF stores only what changed from frame to frame: a viewer must still see each drawn
    frame (in the shared palette), the moving cars change their pixels and the ground does not."""
    from regen.driving.render.frames import Frames, frame, palette, story_of

    scenario, trace = _run(straight_map, seconds=2.0)
    verdict = _verdict([0.0, 0.5, 1.5])
    out = render.render_scenario(scenario, trace, verdict, tmp_path)
    actors, times, view, bg = render.scene(scenario, trace, "test")
    legend = legend_image(legend_entries(actors, view))
    frames = Frames(bg, view, actors, story_of(scenario, trace, verdict), times, legend)
    pal = palette(bg)
    shown = _frames(out[ANIMATION])
    assert len(shown) == trace.steps and shown[0].shape == (480 + legend.height, 640, 3)
    for i in (0, 1, 7, trace.steps - 1):
        drawn = frames.draw(i)
        assert np.array_equal(np.asarray(drawn), np.asarray(frame(bg, view, actors, frames.story, times, i,
                                                                  legend=legend)))
        expected = np.asarray(drawn.quantize(palette=pal, dither=Image.Dither.NONE).convert("RGB"))
        assert np.array_equal(shown[i], expected), i
    # car1 drives east at 4 m/s: in 1 s its body has left the spot it covered at the start
    px, py = view.to_px(trace.actors["car1"].x[0], trace.actors["car1"].y[0])
    spot = np.s_[int(py) - 3: int(py) + 4, int(px) - 3: int(px) + 4]
    assert (shown[0][spot] != shown[10][spot]).any()
    assert np.array_equal(shown[0][:20, :20], shown[-1][:20, :20])  # the far corner stays as it is
    strip = Image.open(out[KEYFRAMES])
    assert strip.size == (4 * 640 + 3 * render.KEYFRAME_GAP, KEY_H)  # start, stages 2 and 3, end


def test_the_map_is_drawn_as_an_axes_over_the_view_draws_it(straight_map):
    """The background puts the shapes on the figure through the transform an axes spanning it
    would use, skipping the axes: the same pixels as drawing them into such an axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    scenario, trace = _run(straight_map)
    layers = render_map.map_layers(scenario, trace)
    for view in (choose_view(actors_from_trace(trace)), render_map.View(9.0, -60.0, 30.0, 1300, 520, "ego")):
        fig = Figure(figsize=(view.width / render_map.DPI, view.height / render_map.DPI), dpi=render_map.DPI,
                     facecolor=tuple(c / 255 for c in render_map.GRASS))
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_axis_off()
        ax.set_xlim(view.x0, view.x0 + view.width / view.scale)
        ax.set_ylim(view.y1 - view.height / view.scale, view.y1)
        for artist in render_map.map_artists(layers, view, ax.transData):
            ax.add_artist(artist)
        canvas.draw()
        expected = np.asarray(canvas.buffer_rgba())[..., :3]
        drawn = np.asarray(render_map.background(layers, view))
        assert drawn.shape == expected.shape and np.array_equal(drawn, expected), view
        assert (drawn != np.asarray(render_map.GRASS)).any(axis=2).mean() > 0.2  # a road, not grass alone


def test_each_key_frame_shows_the_forward_camera_below_the_bird_eye_view(rendered):
    """The camera row of the strip is the ego's forward view at the key frame's time."""
    pytest.importorskip("panda3d")
    from regen.driving.render.camera import camera_frames

    scenario, trace, out = rendered
    strip = np.asarray(Image.open(out[KEYFRAMES]).convert("RGB"))
    assert strip.shape[0] == 480 + 360
    first = camera_frames(scenario, trace, [0.0], size=(640, 360))[0]  # the start tile is t = 0
    assert np.array_equal(strip[480:, :640], np.asarray(first))
    last = strip[480:, -640:]
    assert not np.array_equal(last, np.asarray(first))  # the end tile shows a later view
