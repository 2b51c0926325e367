"""Verified manipulation scenarios as a LeRobot v3 dataset (``codebase_version`` v3.0), written
with pyarrow alone (LeRobot itself is needed only to read it).

Layout (that of ``lerobot`` 0.6.1, ``lerobot.datasets.utils``; read back by 0.4.4's own loader,
:mod:`regen.manipulation.export.lerobot_check`)::

    meta/info.json                          fps, features (dtype, shape, names), path templates
    meta/stats.json                         per feature: min, max, mean, std, count, q01 .. q99
    meta/tasks.parquet                      task text (the pandas index 'task') -> task_index
    meta/episodes/chunk-000/file-000.parquet  one row per episode: its tasks, length, where its
                                            rows are, its stats (``stats/<feature>/<stat>``)
    data/chunk-000/file-000.parquet         one row per frame, one row group per episode

One episode per verified (feasible) scenario of the run folders, in their order; the others are
left out. Frames, state, action and reward: :mod:`regen.manipulation.export.episode`. The two
cameras' pictures (:mod:`regen.manipulation.render.camera`) are PNG files inside the parquet rows
(the ``datasets`` Image struct: ``bytes``, ``path``), not videos: LeRobotDataset reads them
without a video decoder, so ``video_path`` is null. A data file holds episodes up to
:data:`DATA_FILE_MB`, then the next file begins.

Deterministic: the same run folders give byte-identical files. The dataset is written into a
temporary folder beside ``out`` and moved into place; an existing LeRobot dataset at ``out`` is
replaced, any other non-empty folder is left alone (ConfigError).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from regen.core.trace import Trace
from regen.errors import ConfigError, DependencyNotInstalled
from regen.manipulation.export.card import write_card
from regen.manipulation.export.episode import (
    ACTION_COMMAND,
    ACTION_NEXT_STATE,
    ENV_NAMES,
    FPS,
    STATE_NAMES,
    Episode,
    build_episode,
)
from regen.manipulation.export.lerobot_check import DEFAULT_REPO_ID
from regen.manipulation.export.stats import feature_stats, merge_stats
from regen.manipulation.render.camera import CAMERAS, SIZE, replay_cameras

CODEBASE_VERSION = "v3.0"
ROBOT_TYPE = "franka_panda"
CHUNKS_SIZE = 1000  # files per chunk folder (LeRobot's default)
DATA_FILE_MB = 100  # [MB] a data file is closed beyond this (LeRobot's default)
VIDEO_FILE_MB = 200  # [MB] LeRobot's default; no videos are written
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
TASKS_PATH = "meta/tasks.parquet"
IMAGE_KEYS = [f"observation.images.{c}" for c in CAMERAS]


def _pa() -> Any:
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise DependencyNotInstalled("pyarrow", "dataset", "LeRobot datasets") from None
    return pyarrow


def features(with_reward: bool) -> dict[str, dict]:
    """The ``features`` of ``meta/info.json``."""
    w, h = SIZE
    vec = {"dtype": "float32"}
    out: dict[str, dict] = {
        "observation.state": {**vec, "shape": [len(STATE_NAMES)], "names": STATE_NAMES},
        "observation.environment_state": {**vec, "shape": [len(ENV_NAMES)], "names": ENV_NAMES},
        "action": {**vec, "shape": [len(STATE_NAMES)], "names": STATE_NAMES},
    }
    for key in IMAGE_KEYS:
        out[key] = {"dtype": "image", "shape": [h, w, 3], "names": ["height", "width", "channels"]}
    if with_reward:
        out["next.reward"] = {"dtype": "float32", "shape": [1], "names": None}
    out["next.done"] = {"dtype": "bool", "shape": [1], "names": None}
    out["timestamp"] = {"dtype": "float32", "shape": [1], "names": None}
    for key in ("frame_index", "episode_index", "index", "task_index"):
        out[key] = {"dtype": "int64", "shape": [1], "names": None}
    return out


def _hf_feature(ft: dict) -> dict:
    """A feature as the ``datasets`` library describes it (the parquet's ``huggingface`` key)."""
    if ft["dtype"] == "image":
        return {"_type": "Image"}
    value = {"dtype": ft["dtype"], "_type": "Value"}
    return value if ft["shape"] == [1] else {"feature": value, "length": ft["shape"][0], "_type": "List"}


def _arrow_type(pa: Any, ft: dict) -> Any:
    if ft["dtype"] == "image":
        return pa.struct([("bytes", pa.binary()), ("path", pa.string())])
    scalar = {"float32": pa.float32(), "int64": pa.int64(), "bool": pa.bool_()}[ft["dtype"]]
    return scalar if ft["shape"] == [1] else pa.list_(scalar, ft["shape"][0])


def _png(image: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def _columns(ep: Episode, ep_index: int, start: int, task_index: int, action: str,
             images: dict[str, list[np.ndarray]], feats: dict[str, dict]) -> dict[str, Any]:
    """The episode's rows, column by column (numpy arrays; pictures as PNG structs)."""
    n = ep.length
    cols: dict[str, Any] = {"observation.state": ep.state, "observation.environment_state": ep.environment,
                            "action": ep.action(action)}
    for cam, key in zip(CAMERAS, IMAGE_KEYS, strict=True):
        cols[key] = [{"bytes": _png(img), "path": f"frame-{i:06d}.png"} for i, img in enumerate(images[cam])]
    if "next.reward" in feats:
        assert ep.reward is not None
        cols["next.reward"] = ep.reward
    cols["next.done"] = np.arange(n) == n - 1
    cols["timestamp"] = (np.arange(n) / FPS).astype(np.float32)
    cols["frame_index"] = np.arange(n, dtype=np.int64)
    cols["episode_index"] = np.full(n, ep_index, dtype=np.int64)
    cols["index"] = np.arange(start, start + n, dtype=np.int64)
    cols["task_index"] = np.full(n, task_index, dtype=np.int64)
    return cols


def _table(pa: Any, cols: dict[str, Any], feats: dict[str, dict]) -> Any:
    arrays = []
    for key, ft in feats.items():
        typ = _arrow_type(pa, ft)
        values = cols[key]
        if isinstance(values, np.ndarray) and values.ndim == 2:
            flat = pa.array(values.reshape(-1), type=typ.value_type)
            arrays.append(pa.FixedSizeListArray.from_arrays(flat, values.shape[1]))
        else:
            arrays.append(pa.array(values if not isinstance(values, np.ndarray) else values.tolist(), type=typ))
    meta = {"huggingface": json.dumps({"info": {"features": {k: _hf_feature(f) for k, f in feats.items()}}})}
    schema = pa.schema([pa.field(k, _arrow_type(pa, f)) for k, f in feats.items()], metadata=meta)
    return pa.Table.from_arrays(arrays, schema=schema)


class _DataFiles:
    """Writes episodes' rows into ``data/chunk-CCC/file-FFF.parquet``, one row group per
    episode, starting a new file beyond :data:`DATA_FILE_MB`."""

    def __init__(self, root: Path, pa: Any):
        self.root, self.pa = root, pa
        self.chunk, self.file, self.size = 0, 0, 0
        self.writer: Any = None

    def write(self, table: Any) -> tuple[int, int]:
        """Append one episode's table; (chunk, file) it went into."""
        if self.writer is not None and self.size + table.nbytes > DATA_FILE_MB * 1024 * 1024:
            self.close()
            self.file += 1
            if self.file == CHUNKS_SIZE:
                self.chunk, self.file = self.chunk + 1, 0
        if self.writer is None:
            path = self.root / DATA_PATH.format(chunk_index=self.chunk, file_index=self.file)
            path.parent.mkdir(parents=True, exist_ok=True)
            self.writer = self.pa.parquet.ParquetWriter(str(path), table.schema, compression="snappy",
                                                        use_dictionary=True)
            self.size = 0
        self.writer.write_table(table)
        self.size += table.nbytes
        return self.chunk, self.file

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            self.writer = None


def _write_json(path: Path, value: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value, indent=4, ensure_ascii=False) + "\n", encoding="utf-8")


def _write_tasks(pa: Any, root: Path, tasks: list[str]) -> None:
    """``meta/tasks.parquet`` as pandas writes a frame indexed by ``task`` (LeRobot reads it
    with ``pd.read_parquet``: the task text is the index, ``task_index`` the column)."""
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [{"name": None, "field_name": None, "pandas_type": "unicode",
                            "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                     "numpy_type": "int64", "metadata": None},
                    {"name": "task", "field_name": "task", "pandas_type": "unicode",
                     "numpy_type": "object", "metadata": None}],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.0",
    }
    schema = pa.schema([("task_index", pa.int64()), ("task", pa.string())],
                       metadata={"pandas": json.dumps(pandas_meta)})
    table = pa.Table.from_arrays([pa.array(range(len(tasks)), pa.int64()), pa.array(tasks, pa.string())],
                                 schema=schema)
    (root / TASKS_PATH).parent.mkdir(parents=True, exist_ok=True)
    pa.parquet.write_table(table, str(root / TASKS_PATH), compression="snappy")


def _write_episodes(pa: Any, root: Path, rows: list[dict[str, Any]]) -> None:
    """``meta/episodes/chunk-000/file-000.parquet``: one row per episode."""
    names = list(rows[0])
    table = pa.Table.from_pylist(rows, schema=pa.schema(
        [(k, pa.array([r[k] for r in rows]).type) for k in names]))
    path = root / EPISODES_PATH.format(chunk_index=0, file_index=0)
    path.parent.mkdir(parents=True, exist_ok=True)
    pa.parquet.write_table(table, str(path), compression="snappy")


def _info(feats: dict[str, dict], episodes: int, frames: int, tasks: int) -> dict[str, Any]:
    return {"codebase_version": CODEBASE_VERSION, "fps": FPS, "features": feats,
            "total_episodes": episodes, "total_frames": frames, "total_tasks": tasks,
            "chunks_size": CHUNKS_SIZE, "data_files_size_in_mb": DATA_FILE_MB,
            "video_files_size_in_mb": VIDEO_FILE_MB, "data_path": DATA_PATH, "video_path": None,
            "robot_type": ROBOT_TYPE, "splits": {"train": f"0:{episodes}"}}


def _collect(run_dirs: list[Path]) -> tuple[list[tuple[Episode, Any, Trace]], list[str]]:
    """(episode, scenario, trace) of every verified manipulation scenario; the names of the others."""
    from regen.harness.catalog import verified
    from regen.runfolder import ScenarioFolder, read_model

    entries, skipped = verified([Path(r) for r in run_dirs], "manipulation")
    out = []
    for e in entries:
        got = read_model(e.folder / ScenarioFolder.TRACE, Trace)
        if not got.ok:
            skipped.append(f"{e.name} (trace.json {got.problem})")
            continue
        verdict = e.folder.verdict()
        out.append((build_episode(e.name, verdict.status if verdict else "", e.scenario, got.value),
                    e.scenario, got.value))
    return out, skipped


def _write_dataset(root: Path, collected: list[tuple[Episode, Any, Trace]]) -> dict[str, Any]:
    """Every file of the dataset under ``root``; what was written."""
    pa = _pa()
    episodes = [c[0] for c in collected]
    tasks = list(dict.fromkeys(ep.task for ep in episodes))
    action = ACTION_COMMAND if all(ep.command is not None for ep in episodes) else ACTION_NEXT_STATE
    feats = features(with_reward=all(ep.reward is not None for ep in episodes))
    data, rows, per_episode, start = _DataFiles(root, pa), [], [], 0
    motions: dict[str, list[str]] = {}  # what the robot and the world did -> the episodes that did it
    try:
        for k, (ep, scenario, trace) in enumerate(collected):
            images = replay_cameras(scenario, trace, ep.samples)
            cols = _columns(ep, k, start, tasks.index(ep.task), action, images, feats)
            motions.setdefault(_motion_key(cols, images), []).append(ep.name)
            chunk, file = data.write(_table(pa, cols, feats))
            stats = {key: feature_stats(cols[key], images[key.rsplit(".", 1)[1]] if key in IMAGE_KEYS else None)
                     for key in feats}
            per_episode.append(stats)
            row = {"episode_index": k, "tasks": [ep.task], "length": ep.length,
                   "data/chunk_index": chunk, "data/file_index": file, "dataset_from_index": start,
                   "dataset_to_index": start + ep.length, "meta/episodes/chunk_index": 0,
                   "meta/episodes/file_index": 0, "regen/scenario": ep.name, "regen/status": ep.status}
            row.update({f"stats/{key}/{s}": v for key, st in stats.items() for s, v in st.items()})
            rows.append(row)
            start += ep.length
    finally:
        data.close()
    _write_episodes(pa, root, rows)
    _write_tasks(pa, root, tasks)
    _write_json(root / "meta" / "stats.json", merge_stats(per_episode))
    _write_json(root / "meta" / "info.json", _info(feats, len(episodes), start, len(tasks)))
    return {"episodes": len(episodes), "frames": start, "tasks": tasks, "action": action,
            "reward": "next.reward" in feats,
            "same_motion": [names for names in motions.values() if len(names) > 1],
            "episode_list": [{"index": r["episode_index"], "scenario": r["regen/scenario"], "task": r["tasks"][0],
                              "frames": r["length"], "status": r["regen/status"]} for r in rows]}


def _motion_key(cols: dict[str, Any], images: dict[str, list[np.ndarray]]) -> str:
    """A digest of what an episode shows: its states, actions, rewards and pictures, not its task
    text. Two episodes with the same digest are the same motion in the same world: contexts that
    differ only in words the simulation does not show (a person who is no asset of the scene)."""
    h = hashlib.sha256()
    for key in ("observation.state", "observation.environment_state", "action", "next.reward"):
        if key in cols:
            h.update(key.encode() + np.ascontiguousarray(cols[key]).tobytes())
    for cam in sorted(images):
        for img in images[cam]:
            h.update(np.ascontiguousarray(img).tobytes())
    return h.hexdigest()


def _is_dataset(path: Path) -> bool:
    return (path / "meta" / "info.json").is_file()


def _check_out(out: Path) -> None:
    if out.exists() and not (out.is_dir() and (_is_dataset(out) or not any(out.iterdir()))):
        raise ConfigError(f"{out} exists and is not a LeRobot dataset: regen replaces only a dataset "
                          "it wrote; give another output folder or move that one aside")


def _move_into_place(tmp: Path, out: Path) -> None:
    if not out.exists():
        tmp.rename(out)
        return
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    out.rename(old)
    tmp.rename(out)
    shutil.rmtree(old, ignore_errors=True)


def write_lerobot(run_dirs: list[Path], out: Path) -> dict[str, Any]:
    """Write the verified manipulation scenarios of ``run_dirs`` as a LeRobot v3 dataset at
    ``out`` (one episode each, :data:`~regen.manipulation.export.episode.FPS` frames per second,
    128x128 px scene and wrist pictures). Returns what was written: ``path``, ``episodes``,
    ``frames``, ``tasks``, ``fps``, ``action`` (what the action column holds), ``reward``
    (whether ``next.reward`` is there), ``skipped`` (scenarios left out). ConfigError when no
    scenario verified or ``out`` is a folder that is not a dataset."""
    out = Path(out)
    _pa()
    _check_out(out)
    collected, skipped = _collect(list(run_dirs))
    if not collected:
        raise ConfigError(f"no verified manipulation scenario in {', '.join(str(r) for r in run_dirs)}"
                          + (f" (left out: {', '.join(skipped)})" if skipped else ""))
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    tmp.chmod(0o755)  # mkdtemp's folder is the user's alone; a dataset is shared like any output
    try:
        written = _write_dataset(tmp, collected)
        info = {"format": "lerobot", "codebase_version": CODEBASE_VERSION, "path": str(out), "fps": FPS,
                "cameras": list(IMAGE_KEYS), "image_size": list(SIZE), **written, "skipped": skipped}
        write_card(tmp, info, DEFAULT_REPO_ID)
        _move_into_place(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return info


__all__ = ["CODEBASE_VERSION", "DATA_PATH", "EPISODES_PATH", "FPS", "IMAGE_KEYS", "TASKS_PATH", "features",
           "write_lerobot"]
