"""The ego's forward camera (Panda3D, software display): where actors appear in the frame, the
states that must show, determinism, and maps that are missing or real."""

from __future__ import annotations

import logging
import math
import sys

import numpy as np
import pytest

pytest.importorskip("panda3d")

from regen.core.behavior import Behavior  # noqa: E402
from regen.core.scenario import FSM, Entity, Scenario  # noqa: E402
from regen.core.trace import ActorTrack, Trace  # noqa: E402
from regen.driving.render import camera  # noqa: E402
from regen.driving.render.actors import BRAKE, HAZARD, LIGHT_COLORS, SIREN_BLUE, SIREN_RED  # noqa: E402
from regen.driving.render.roads import MARK_YELLOW, ROAD  # noqa: E402
from regen.errors import ConfigError  # noqa: E402

W, H = camera.SIZE
EGO_X, EGO_Y = 10.0, 20.0  # [m]


def _scenario(names: dict[str, str]) -> Scenario:
    return Scenario(
        id="camera-test", domain="driving",
        behavior=Behavior(text="the ego-vehicle stops", domain="driving"),
        causal_graph=["cause", "the ego-vehicle stops"], narrative="test",
        entities=[Entity(name=n, asset=a, kind="ego" if n == "ego" else "agent") for n, a in names.items()],
        fsm=FSM(states=[], stages=[]),
    )


def _trace(others: dict[str, dict], heading: float = 0.0, steps: int = 3, meta: dict | None = None,
           ego_at: tuple[float, float] = (EGO_X, EGO_Y)) -> tuple[Scenario, Trace]:
    """The ego at ``ego_at`` heading ``heading`` [rad]; each other actor is
    ``{"asset", "at": (ahead, left) [m] from the ego's centre in its frame, ...ActorTrack fields}``,
    facing the way the ego does, standing still."""
    n = steps
    c, s = math.cos(heading), math.sin(heading)
    actors = {"ego": ActorTrack(asset="sedan", kind="ego", length=4.6, width=1.9, height=1.5,
                                x=[ego_at[0]] * n, y=[ego_at[1]] * n, heading=[heading] * n)}
    for name, spec in others.items():
        spec = dict(spec)
        fwd, left = spec.pop("at")
        x, y = ego_at[0] + fwd * c - left * s, ego_at[1] + fwd * s + left * c
        states = {k: [v] * n for k, v in spec.pop("states", {}).items()}
        actors[name] = ActorTrack(x=[x] * n, y=[y] * n, heading=[heading] * n, states=states, **spec)
    trace = Trace(dt=0.1, times=[round(0.1 * k, 6) for k in range(n)], actors=actors, meta=meta or {})
    return _scenario({k: a.asset for k, a in actors.items()}), trace


def _frame(others: dict[str, dict], heading: float = 0.0, t: float = 0.0, **kw) -> np.ndarray:
    scenario, trace = _trace(others, heading)
    return np.asarray(camera.camera_frames(scenario, trace, [t], **kw)[0])


def _mask(others: dict[str, dict], heading: float = 0.0, t: float = 0.0) -> np.ndarray:
    """Pixels the actors change, against the frame of the ego alone."""
    return np.any(_frame(others, heading, t) != _frame({}, heading, t), axis=2)


def _is(img: np.ndarray, rgb) -> np.ndarray:
    """Pixels of color ``rgb``, give or take the software renderer's rounding (a unit or two)."""
    return np.all(np.abs(img.astype(int) - np.asarray(rgb)) <= 2, axis=-1)


def _count(img: np.ndarray, rgb) -> int:
    return int(_is(img, rgb).sum())


def _sedan(ahead: float, left: float, **states) -> dict:
    return {"asset": "sedan", "length": 4.6, "width": 1.9, "height": 1.5, "at": (ahead, left),
            "states": states}


@pytest.mark.parametrize("heading", [0.0, 1.2, -2.5])
def test_actor_straight_ahead_is_centred(heading):
    mask = _mask({"car1": _sedan(20.0, 0.0)}, heading)
    cols = np.nonzero(mask)[1]
    assert len(cols) > 300, "the car ahead is not in the frame"
    assert abs(cols.mean() - W / 2) < 0.03 * W
    rows = np.nonzero(mask)[0]
    assert rows.min() < H / 2 < rows.max(), "a car 20 m ahead straddles the horizon"


@pytest.mark.parametrize("heading", [0.0, 2.0])
def test_actor_on_the_left_is_left_of_centre_and_right_is_right(heading):
    left = np.nonzero(_mask({"car1": _sedan(20.0, 6.0)}, heading))[1]
    right = np.nonzero(_mask({"car1": _sedan(20.0, -6.0)}, heading))[1]
    assert len(left) > 200 and len(right) > 200
    # 6 m aside at 20 m ahead (~18 m from the camera) is ~100 px off centre at a 90 degree view
    assert left.mean() < 0.4 * W
    assert right.mean() > 0.6 * W


def test_actor_behind_the_ego_is_not_seen():
    assert not _mask({"car1": _sedan(-15.0, 0.0)}).any()


def _light(state: str) -> dict:
    return {"light1": {"asset": "traffic_light", "kind": "object", "length": 0.3, "width": 0.3,
                       "height": 4.0, "at": (15.0, 0.0), "states": {"light_state": state}}}


def _reddish(px: np.ndarray) -> np.ndarray:
    return (px[:, 0] > 180) & (px[:, 1] < 90) & (px[:, 2] < 90)


def _greenish(px: np.ndarray) -> np.ndarray:
    return (px[:, 1] > 180) & (px[:, 0] < 120) & (px[:, 2] < 150)


def test_traffic_light_lamp_shows_its_state():
    off, red, green = (_frame(_light(s)) for s in ("off", "red", "green"))
    red_lamp = np.any(red != off, axis=2)
    green_lamp = np.any(green != off, axis=2)
    assert red_lamp.sum() > 30 and green_lamp.sum() > 30, "the lit lamp does not show"
    assert _reddish(red[red_lamp]).mean() > 0.9
    assert _greenish(green[green_lamp]).mean() > 0.9
    assert not _greenish(red.reshape(-1, 3)).any() and not _reddish(green.reshape(-1, 3)).any()
    # red on top, green at the bottom of the head
    assert np.nonzero(red_lamp)[0].mean() < np.nonzero(green_lamp)[0].mean()
    assert _count(red, LIGHT_COLORS["red"]) > 30 and _count(green, LIGHT_COLORS["green"]) > 30


def test_open_door_sticks_out_on_the_left():
    parked = {"asset": "parked_car", "kind": "object", "length": 4.6, "width": 1.9, "height": 1.5,
              "at": (12.0, 0.0)}
    closed = _frame({"p": {**parked, "states": {"door": "closed"}}})
    opened = _frame({"p": {**parked, "states": {"door": "open"}}})
    changed = np.any(opened != closed, axis=2)
    assert changed.sum() > 100
    body = np.nonzero(_mask({"p": {**parked, "states": {"door": "closed"}}}))[1]
    assert np.nonzero(changed)[1].mean() < body.min() + 0.25 * (body.max() - body.min())


def test_brake_lights_are_bright_only_when_on():
    on = _frame({"car1": _sedan(10.0, 0.0, brake_lights="on")})
    off = _frame({"car1": _sedan(10.0, 0.0, brake_lights="off")})
    assert _count(on, BRAKE) > 40
    assert _count(off, BRAKE) == 0


def test_hazard_lights_flash_amber():
    car = {"p": {"asset": "parked_car", "kind": "object", "length": 4.6, "width": 1.9, "height": 1.5,
                 "at": (10.0, 0.0), "states": {"hazard_lights": "on"}}}
    assert _count(_frame(car, t=0.0), HAZARD) > 10  # int(3 t) even: lit
    scenario, trace = _trace(car, steps=5)
    dark = np.asarray(camera.camera_frames(scenario, trace, [0.4])[0])  # int(3 t) odd: dark
    assert _count(dark, HAZARD) == 0


def test_siren_shows_red_and_blue_on_the_roof():
    amb = {"asset": "ambulance", "length": 6.4, "width": 2.4, "height": 2.9, "at": (14.0, 0.0)}
    on = _frame({"a": {**amb, "states": {"siren": "on"}}})
    off = _frame({"a": {**amb, "states": {"siren": "off"}}})
    assert _count(on, SIREN_RED) > 10 and _count(on, SIREN_BLUE) > 10
    assert _count(off, SIREN_RED) == 0 and _count(off, SIREN_BLUE) == 0
    rows = np.nonzero(_is(on, SIREN_RED))[0]
    assert rows.max() < H / 2, "the siren is on the roof, above the camera's horizon"


def test_pedestrian_stands_upright_with_a_head():
    adult = {"adult1": {"asset": "adult", "length": 0.5, "width": 0.5, "height": 1.8, "at": (10.0, 0.0)}}
    mask = _mask(adult)
    rows, cols = np.nonzero(mask)
    assert len(rows) > 100
    assert (rows.max() - rows.min()) > 2.5 * (cols.max() - cols.min())
    assert rows.min() < H / 2 < rows.max(), "a 1.8 m figure reaches above a 1.2 m eye"
    top = _frame(adult)[rows.min():rows.min() + 3][mask[rows.min():rows.min() + 3]]
    skin = np.asarray(camera.SKIN, float)
    shade = top.sum(axis=1, keepdims=True) / skin.sum()  # faces are shaded: a darker skin is skin
    assert len(top) and (np.abs(top - shade * skin) <= 4).all(), "no head on top"


def test_every_asset_renders():
    from regen.driving.assets import database

    others = {}
    for k, (name, spec) in enumerate(sorted(database().assets.items())):
        if spec.kind == "sensor":
            continue
        length, width, height = spec.size
        others[f"a{k}"] = {"asset": name, "kind": spec.kind, "length": length, "width": width,
                           "height": height, "at": (25.0 + 18.0 * (k % 6), -12.0 + 6.0 * (k // 6))}
    assert _mask(others).sum() > 1000


def test_frames_are_byte_identical_across_calls():
    others = {"car1": _sedan(18.0, 3.5, brake_lights="on"), **_light("red")}
    scenario, trace = _trace(others, heading=0.7)
    first = camera.camera_frames(scenario, trace, [0.0, 0.1])
    second = camera.camera_frames(scenario, trace, [0.0, 0.1])
    assert [f.tobytes() for f in first] == [f.tobytes() for f in second]
    assert all(f.size == (W, H) and f.mode == "RGB" for f in first)


def test_size_and_nearest_step():
    scenario, trace = _trace({"car1": _sedan(15.0, 0.0)}, steps=5)
    trace.actors["car1"].x[:] = [EGO_X + 10.0 + 5.0 * k for k in range(5)]  # moves away 5 m a step
    frames = camera.camera_frames(scenario, trace, [0.0, 0.26, 0.3, 9.0], size=(320, 180))
    assert all(f.size == (320, 180) for f in frames)
    assert frames[1].tobytes() == frames[2].tobytes()  # 0.26 s is nearest step 3 (0.3 s)
    assert frames[0].tobytes() != frames[1].tobytes()
    assert frames[3].tobytes() == camera.camera_frames(scenario, trace, [0.4], size=(320, 180))[0].tobytes()


def test_missing_map_is_plain_ground(tmp_path, caplog):
    scenario, trace = _trace({"car1": _sedan(15.0, 0.0)})
    with caplog.at_level(logging.WARNING):
        img = np.asarray(camera.camera_frames(scenario, trace, [0.0], map_path=tmp_path / "none.xodr")[0])
    assert "none.xodr" in caplog.text
    assert _is(img[0, 0], camera.SKY) and _is(img[-1, 0], camera.GROUND)
    assert _count(img, ROAD) == 0


def test_map_named_but_missing_in_the_trace_is_plain_ground(tmp_path):
    scenario, trace = _trace({}, meta={"map_path": str(tmp_path / "gone.xodr"), "map": "no_such_map"})
    img = np.asarray(camera.camera_frames(scenario, trace, [0.0])[0])
    assert _is(img[-1, W // 2], camera.GROUND)


@pytest.fixture
def road_map(request):
    pytest.importorskip("scenic")
    return request.getfixturevalue("straight_map")


def test_road_ahead_on_a_real_map(road_map):
    # the generated straight road runs along x; east-bound lanes are at y < 0
    scenario, trace = _trace({"car1": _sedan(20.0, 0.0)}, ego_at=(-20.0, -1.75),
                             meta={"map": "straight", "map_path": str(road_map)})
    img = np.asarray(camera.camera_frames(scenario, trace, [0.0])[0])
    assert _is(img[-5, W // 2], ROAD), "the road is under the camera"
    assert _count(img[H // 2:], ROAD) > 0.3 * (H // 2) * W
    yellow = np.nonzero(_is(img, MARK_YELLOW))[1]
    assert len(yellow) > 100 and yellow.mean() < W / 2, "the centre line is on the ego's left"
    assert _is(img[0, 0], camera.SKY)


def test_no_ego_is_a_config_error():
    scenario, trace = _trace({"car1": _sedan(15.0, 0.0)})
    trace.actors.pop("ego")
    with pytest.raises(ConfigError, match="no ego"):
        camera.camera_frames(scenario, trace, [0.0])


def test_missing_panda3d_names_the_extra(monkeypatch):
    monkeypatch.setattr(camera, "_renderer", camera._renderer.__wrapped__)  # a fresh engine's import
    monkeypatch.setitem(sys.modules, "panda3d.core", None)
    assert not camera.camera_available()
    scenario, trace = _trace({})
    with pytest.raises(ImportError, match=r"pip install -e '\.\[camera\]'") as info:
        camera.camera_frames(scenario, trace, [0.0])
    assert isinstance(info.value, camera.CameraNotInstalled)
    monkeypatch.undo()
    assert camera.camera_available()
