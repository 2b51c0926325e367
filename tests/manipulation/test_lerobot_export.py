"""Verified manipulation scenarios as a LeRobot v3 dataset: the layout, the columns, one episode
per verified scenario, byte-identical rewrites; and LeRobot's own LeRobotDataset reads it, run in
LeRobot's environment (.venv-lerobot: skipped where it is missing, failed on CI)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

pytest.importorskip("pybullet")
pa = pytest.importorskip("pyarrow", reason="the 'dataset' extra is not installed")
import pyarrow.parquet as pq  # noqa: E402

from regen.errors import ConfigError  # noqa: E402
from regen.manipulation.export import write_lerobot  # noqa: E402

pytestmark = pytest.mark.slow

CASSETTE = Path(__file__).resolve().parents[1] / "data" / "cassettes" / "generate_manipulation_door.json"
FILES = ["README.md", "data/chunk-000/file-000.parquet", "meta/episodes/chunk-000/file-000.parquet", "meta/info.json",
         "meta/stats.json", "meta/tasks.parquet"]


@pytest.fixture(scope="module")
def door_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A two-scenario 'open the door' run, replayed from its cassette (no model call)."""
    from typer.testing import CliRunner

    from regen.cli import app
    from regen.llm.cache import CallCache

    run = tmp_path_factory.mktemp("runs") / "door"
    run.mkdir()
    CallCache(run / "llm-cache.sqlite").import_json(CASSETTE)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        res = CliRunner().invoke(app, ["generate", "the robot opens the door", "-d", "manipulation", "--out",
                                       str(run), "--replay", "-n", "2", "--depth", "1", "--causes", "3",
                                       "--no-pictures"])
    assert res.exit_code == 0, res.output
    return run


@pytest.fixture(scope="module")
def dataset(door_run: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("datasets") / "door"
    return out, write_lerobot([door_run], out)


def _traces(run: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(run.glob("scenarios/*/trace.json"))]


def test_the_layout_and_info(dataset) -> None:
    out, summary = dataset
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == sorted(FILES)
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 12 and info["robot_type"] == "franka_panda"
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] is None  # pictures are PNGs inside the parquet rows
    assert info["total_episodes"] == summary["episodes"] == 2 and info["total_tasks"] == 2
    assert info["chunks_size"] == 1000 and info["splits"] == {"train": "0:2"}
    f = info["features"]
    assert f["observation.state"] == {"dtype": "float32", "shape": [9], "names": f["action"]["names"]}
    assert f["observation.state"]["names"][0] == "panda_joint1"
    assert f["observation.environment_state"]["shape"] == [13]
    for cam in ("scene", "wrist"):
        assert f[f"observation.images.{cam}"] == {"dtype": "image", "shape": [128, 128, 3],
                                                   "names": ["height", "width", "channels"]}
    for key in ("timestamp", "frame_index", "episode_index", "index", "task_index", "next.reward", "next.done"):
        assert f[key]["shape"] == [1], key
    stats = json.loads((out / "meta" / "stats.json").read_text())
    assert set(stats) == set(f) and len(stats["action"]["mean"]) == 9
    scene = stats["observation.images.scene"]  # per channel, shaped (3, 1, 1), in [0, 1]
    assert [len(c) for c in scene["mean"]] == [1, 1, 1] and all(0 < c[0][0] < 1 for c in scene["mean"])
    assert summary["action"].startswith("commanded joint targets") and summary["reward"] is True


def test_the_columns_agree_with_the_traces(dataset, door_run) -> None:
    out, _ = dataset
    info = json.loads((out / "meta" / "info.json").read_text())
    data = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet")
    assert data.column_names == list(info["features"])
    traces = _traces(door_run)
    lengths = [(len(t["times"]) + 1) // 2 for t in traces]  # 24 Hz trace samples at 12 fps
    assert data.num_rows == info["total_frames"] == sum(lengths)
    assert pq.read_metadata(out / "data" / "chunk-000" / "file-000.parquet").num_row_groups == 2
    cols = data.to_pydict()
    assert cols["index"] == list(range(data.num_rows))
    assert cols["episode_index"] == [0] * lengths[0] + [1] * lengths[1]
    assert cols["frame_index"][:lengths[0]] == list(range(lengths[0]))
    assert cols["timestamp"][:3] == pytest.approx([0.0, 1 / 12, 2 / 12])
    assert cols["next.done"].count(True) == 2 and cols["next.done"][lengths[0] - 1]
    robot = traces[0]["actors"]["robot"]["states"]
    assert cols["observation.state"][1] == pytest.approx([robot[f"q{k}"][2] for k in range(9)], abs=1e-6)
    assert cols["action"][1] == pytest.approx([robot[f"cmd_q{k}"][4] for k in range(9)], abs=1e-6)
    png = cols["observation.images.wrist"][0]["bytes"]
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    eps = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pydict()
    assert eps["length"] == lengths and eps["dataset_from_index"] == [0, lengths[0]]
    assert eps["dataset_to_index"] == [lengths[0], sum(lengths)] and eps["data/file_index"] == [0, 0]
    tasks = pq.read_table(out / "meta" / "tasks.parquet").to_pydict()
    assert tasks["task_index"] == [0, 1]
    assert all(t.startswith("the robot opens the door \u2014 context: ") for t in tasks["task"])
    assert eps["tasks"] == [[t] for t in tasks["task"]]


def test_two_writes_are_byte_identical(dataset, door_run, tmp_path: Path) -> None:
    out, _ = dataset
    again = tmp_path / "again"
    write_lerobot([door_run], again)
    for name in FILES:
        assert (out / name).read_bytes() == (again / name).read_bytes(), name


def test_a_scenario_that_did_not_verify_is_left_out(door_run, tmp_path: Path) -> None:
    run = tmp_path / "door"
    shutil.copytree(door_run, run)
    first, second = sorted(run.glob("scenarios/*/"))
    verdict = json.loads((second / "verdict.json").read_text())
    verdict.update(feasible=False, status="fsm_incomplete")
    (second / "verdict.json").write_text(json.dumps(verdict))
    trace = json.loads((first / "trace.json").read_text())  # a trace recorded before cmd_q* were kept
    for k in range(9):
        del trace["actors"]["robot"]["states"][f"cmd_q{k}"]
    (first / "trace.json").write_text(json.dumps(trace))
    summary = write_lerobot([run], tmp_path / "ds")
    assert summary["episodes"] == 1 and summary["skipped"] == [f"door/{second.name}"]
    assert summary["action"].startswith("the next frame's joint positions")
    cols = pq.read_table(tmp_path / "ds" / "data" / "chunk-000" / "file-000.parquet").to_pydict()
    assert set(cols["episode_index"]) == {0}
    assert cols["action"][0] == pytest.approx(cols["observation.state"][1])


def test_a_folder_that_is_not_a_dataset_is_not_replaced(door_run, tmp_path: Path) -> None:
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    with pytest.raises(ConfigError, match="is not a LeRobot dataset"):
        write_lerobot([door_run], tmp_path / "mine")
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


def test_lerobot_dataset_reads_it(dataset, lerobot_python) -> None:
    """LeRobot's own LeRobotDataset, run in its environment (.venv-lerobot), reads every frame
    of both episodes, with the shapes and the task written."""
    from regen.manipulation.export.lerobot_check import agrees, check_lerobot

    out, summary = dataset
    got = check_lerobot(out, repo_id="regen/open-door")
    assert got["frames"] == got["rows"] == summary["frames"] and got["episodes"] == 2 and got["fps"] == 12
    assert got["features"] == list(json.loads((out / "meta" / "info.json").read_text())["features"])
    for item in (got["first"], got["last"]):
        assert item["observation.state"] == [9] and item["action"] == [9]
        assert item["observation.environment_state"] == [13]
        assert item["observation.images.scene"] == item["observation.images.wrist"] == [3, 128, 128]
    assert got["last_index"] == summary["frames"] - 1
    assert got["task"] == summary["tasks"][0]
    assert agrees(got, summary) == []
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()) == sorted(FILES)  # read only


def test_regen_dataset_format_lerobot_writes_the_same_episodes(door_run: Path, dataset, tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """The command users run (``regen dataset RUN --format lerobot``) writes what write_lerobot
    writes, and says it was not checked where LeRobot's environment is missing; a manipulation
    run without --format lerobot, or lerobot beside another format, is refused with what to pass
    (exit 2)."""
    from typer.testing import CliRunner

    from regen.cli import app

    out, _ = dataset
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(tmp_path / "no-venv"))
    res = CliRunner().invoke(app, ["dataset", str(door_run), "--out", str(tmp_path / "ds"), "--format", "lerobot"])
    assert res.exit_code == 0, res.output
    assert "LeRobot v3 dataset" in res.output
    assert (f"not checked with LeRobot's loader: {tmp_path / 'no-venv'} (REGEN_LEROBOT_VENV) not found: "
            "setup.sh creates .venv-lerobot") in res.output
    for f in FILES:
        if f != "README.md":
            assert (tmp_path / "ds" / f).read_bytes() == (out / f).read_bytes(), f
    card = (tmp_path / "ds" / "README.md").read_text()
    assert card.startswith((out / "README.md").read_text())  # the card, then what the check said
    assert card.endswith("## Read back by LeRobot\n\nnot checked with LeRobot's loader: "
                         f"{tmp_path / 'no-venv'} (REGEN_LEROBOT_VENV) not found: setup.sh creates .venv-lerobot\n")
    res = CliRunner().invoke(app, ["dataset", str(door_run), "--out", str(tmp_path / "vla")])
    assert res.exit_code == 2 and "--format lerobot" in res.output, res.output
    res = CliRunner().invoke(app, ["dataset", str(door_run), "--out", str(tmp_path / "x"), "--format", "lerobot",
                                   "--format", "llava"])
    assert res.exit_code == 2 and "written alone" in res.output, res.output


def test_regen_dataset_format_lerobot_checks_with_lerobot(door_run: Path, dataset, lerobot_python: Path,
                                                          tmp_path: Path) -> None:
    """Where LeRobot's environment is installed, the command reads the dataset back with
    LeRobotDataset and says so."""
    from typer.testing import CliRunner

    from regen.cli import app

    _, summary = dataset
    res = CliRunner().invoke(app, ["dataset", str(door_run), "--out", str(tmp_path / "ds"), "--format", "lerobot"])
    assert res.exit_code == 0, res.output
    assert re.search(rf"checked with LeRobot \S+'s LeRobotDataset: 2 episodes, {summary['frames']} frames at 12 fps",
                     res.output), res.output
    card = (tmp_path / "ds" / "README.md").read_text()
    assert re.search(rf"## Read back by LeRobot\n\nchecked with LeRobot \S+'s LeRobotDataset: 2 episodes, "
                     rf"{summary['frames']} frames at 12 fps\n$", card), card


def test_regen_dataset_format_lerobot_fails_when_lerobot_cannot_read_it(door_run: Path, tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A loader that fails is an error (exit 2) naming the dataset and ending with its stderr,
    not a note (a stand-in python plays the failing loader)."""
    from typer.testing import CliRunner

    from regen.cli import app

    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").write_text("#!/bin/sh\necho 'ValueError: no such feature' >&2\nexit 1\n")
    (venv / "bin" / "python").chmod(0o755)
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(venv))
    res = CliRunner().invoke(app, ["dataset", str(door_run), "--out", str(tmp_path / "ds"), "--format", "lerobot"])
    assert res.exit_code == 2, res.output
    assert f"the LeRobot dataset was written at {tmp_path / 'ds'}, but LeRobot's LeRobotDataset could not read" \
        in " ".join(res.output.split()), res.output
    assert "ValueError: no such feature" in res.output


def test_the_card_lists_every_episode_where_it_came_from_and_the_same_motion(dataset) -> None:
    """README.md: one table row per episode with its scenario, task, frames and verdict as the
    episode table holds them; the same-motion episodes named; how to load it."""
    out, summary = dataset
    card = (out / "README.md").read_text()
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    tasks = pq.read_table(out / "meta" / "tasks.parquet").to_pandas()
    assert len(episodes) == 2
    for ep in episodes:
        row = (f"| {ep['episode_index']} | {ep['regen/scenario']} | {ep['tasks'][0]} | {ep['length']} | "
               f"{ep['regen/status']} |")
        assert row in card.splitlines(), row
    assert len(tasks) == 2 and f"{summary['frames']} frames at 12 fps" in card
    assert "- Episodes 0, 1 (" in card and "they are duplicates" in card
    assert 'LeRobotDataset("regen/episodes", root=' in card
    assert "## Read back by LeRobot" not in card  # write_lerobot alone checks nothing


def test_episodes_that_show_the_same_motion_are_named(dataset, door_run: Path) -> None:
    """The door run's two contexts differ only in who needs the door open (no asset of the
    scene): the same states, actions and pictures, named as one motion; the CLI says so."""
    out, summary = dataset
    names = sorted(p.name for p in (door_run / "scenarios").iterdir() if (p / "trace.json").is_file())
    table = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet").to_pydict()
    by_episode: dict[int, list] = {}
    for e, s, a in zip(table["episode_index"], table["observation.state"], table["action"], strict=True):
        by_episode.setdefault(e, []).append((s, a))
    identical = by_episode[0] == by_episode[1]
    assert summary["same_motion"] == ([names] if identical else [])
    assert identical  # as measured: the child and the guest are not in the simulated scene


def test_the_motion_key_reads_what_the_episode_shows_not_its_text() -> None:
    import numpy as np

    from regen.manipulation.export.lerobot import _motion_key

    state = np.zeros((3, 9), dtype=np.float32)
    cols = {"observation.state": state, "observation.environment_state": np.ones((3, 13), dtype=np.float32),
            "action": state + 1, "task_index": np.zeros(3)}
    images = {"scene": [np.zeros((4, 4, 3), dtype=np.uint8)] * 3, "wrist": [np.ones((4, 4, 3), dtype=np.uint8)] * 3}
    key = _motion_key(cols, images)
    assert _motion_key({**cols, "task_index": np.ones(3)}, images) == key  # another task: the same motion
    moved = state.copy()
    moved[2, 0] = 1e-3
    assert _motion_key({**cols, "observation.state": moved}, images) != key
    other = {**images, "wrist": [np.ones((4, 4, 3), dtype=np.uint8)] * 2 + [np.zeros((4, 4, 3), dtype=np.uint8)]}
    assert _motion_key(cols, other) != key
