"""A recorded ego trajectory as the behavior: the CSV reader's one-line errors, and the detector
on every ego template's own simulated trajectory (Scenic), resampled at 10 and 20 Hz, with and
without 10 cm of position noise."""

from __future__ import annotations

import math

import numpy as np
import pytest
from driving_chains import FEASIBLE

from regen.driving.world.recorded import CLASSES, Trajectory, detect, read_trajectory
from regen.errors import ConfigError

pytest.importorskip("scenic")


@pytest.fixture(scope="module")
def template_tracks(tmp_path_factory):
    """template id -> (t, x, y, map name) of the scripted ego in its first hand-written chain."""
    import json

    from regen.core.trace import Trace
    from regen.pipeline.stages import run_path

    root = tmp_path_factory.mktemp("tracks")
    out = {}
    for tid, paths in FEASIBLE.items():
        assert run_path(paths[0], root / tid, pictures=False).verdict.feasible
        tr = Trace.model_validate_json((root / tid / "trace.json").read_text())
        ego = tr.actors["ego"]
        world = json.loads((root / tid / "scenario.json").read_text())["scenario"]["world"]
        out[tid] = (np.asarray(tr.times), np.asarray(ego.x), np.asarray(ego.y), world["map"])
    return out


@pytest.mark.slow
@pytest.mark.parametrize("hz", [10, 20])
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_every_template_is_detected_as_its_class_and_time(template_tracks, hz, noise):
    from regen.driving.world.egos import EGO_TEMPLATES

    rng = np.random.default_rng(hz)
    for tid, (t, x, y, map_name) in template_tracks.items():
        tt = np.arange(t[0], t[-1] + 1e-9, 1.0 / hz)
        xx = np.interp(tt, t, x) + rng.normal(0, noise, len(tt))
        yy = np.interp(tt, t, y) + rng.normal(0, noise, len(tt))
        d = detect(Trajectory(t=tt, x=xx, y=yy, source=tid), map_name=map_name)
        assert d.template == tid, (tid, d.behavior, d.evidence)
        limit = 0.5 if noise == 0 else 0.8
        assert abs(d.event_time - EGO_TEMPLATES[tid].t_event) <= limit, (tid, d.event_time)
        assert d.text == CLASSES[d.behavior][1]


@pytest.mark.slow
def test_without_the_map_a_stop_in_the_junction_is_a_stop(template_tracks):
    t, x, y, _ = template_tracks["stop_in_intersection"]
    d = detect(Trajectory(t=t, x=x - x[0], y=y - y[0]))  # ego-start frame
    assert d.behavior == "stop_abruptly"


def _turn(direction: int) -> Trajectory:
    """A hand-made 90 degree turn at 6 m/s on a 15 m radius, 10 Hz, in an ego-start frame."""
    t = np.arange(0.0, 12.0, 0.1)
    s = 6.0 * t
    x, y = np.empty_like(s), np.empty_like(s)
    arc_len = 15.0 * math.pi / 2
    for k, d in enumerate(s):
        if d < 20:
            x[k], y[k] = d, 0.0
        elif d < 20 + arc_len:
            a = (d - 20) / 15.0
            x[k], y[k] = 20 + 15 * math.sin(a), direction * 15 * (1 - math.cos(a))
        else:
            x[k], y[k] = 35, direction * (15 + d - 20 - arc_len)
    return Trajectory(t=t, x=x, y=y)


def test_hand_made_turns_left_and_right():
    left, right = detect(_turn(+1)), detect(_turn(-1))
    assert (left.behavior, right.behavior) == ("turn_left", "turn_right")
    assert left.template is None and abs(left.event_time - 20 / 6.0) < 0.6


@pytest.mark.parametrize(("text", "words"), [
    ("", "is empty"),
    ("t,x\n0,0\n0.1,1\n", "has no column y"),
    ("t,x,y\n0,0,0\n", "has 1 row(s)"),
    ("t,x,y\n0,0,0\n0.1,nan,0\n", "row 3: x = nan is not finite"),
    ("t,x,y\n0,0,0\n0.1,1,0\n0.1,2,0\n", "time does not increase at row 4"),
    ("t,x,y\n0,0,0\n0.1,one,0\n", "row 3: x = 'one' is not a number"),
    ("t,x,y\n" + "".join(f"{k / 10},{(k / 10) ** 2 * 40},0\n" for k in range(30)), "beyond any car"),
])
def test_bad_files_are_one_line(tmp_path, text, words):
    f = tmp_path / "ego.csv"
    f.write_text(text)
    with pytest.raises(ConfigError, match="trajectory") as err:
        read_trajectory(f)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_good_file_with_optional_columns_reads(tmp_path):
    rows = "".join(f"{k / 10},{k},0,0,10\n" for k in range(40))
    f = tmp_path / "ego.csv"
    f.write_text("t,x,y,heading,speed\n" + rows)
    traj = read_trajectory(f)
    assert len(traj.t) == 40 and traj.speed is not None and traj.heading is not None
    with pytest.raises(ConfigError, match="no behavior class fits"):
        detect(traj)  # constant speed straight ahead: nothing happens
