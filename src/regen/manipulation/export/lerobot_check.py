"""LeRobot's own loader over a dataset :func:`~regen.manipulation.export.lerobot.write_lerobot`
wrote: ``lerobot.datasets.lerobot_dataset.LeRobotDataset`` opens it, and its length, episodes,
fps, features and first and last items are read back.

LeRobot needs another torch and ``datasets`` than this project, so ``setup.sh`` installs it into
a virtual environment of its own (``.venv-lerobot`` beside the checkout, or the folder named by
``REGEN_LEROBOT_VENV``), the way the ASAM checkers live in ``.venv-qc``. That environment holds
no regen: the loader is the fixed script :data:`LOADER` (it imports only ``json``, ``sys`` and
``lerobot``), run by that environment's python in isolated mode (``-I``: no PYTHONPATH, no
current folder on the path) with the dataset folder as its argument and an environment built
from a short allow-list, offline (``HF_HUB_OFFLINE``, ``HF_DATASETS_OFFLINE``) and with the
Hugging Face caches in a temporary folder. Nothing here imports lerobot.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from regen.errors import ConfigError, RegenError


class LeRobotCheckError(RegenError):
    """LeRobot's loader could not read a dataset, or read something else than was written."""


DEFAULT_REPO_ID = "regen/episodes"  # a local root only: the name is never looked up on the Hub
TIMEOUT = 600.0  # [s] the import of torch and datasets, and the parquet files mapped into the cache
MARK = "REGEN-LEROBOT-CHECK "  # the result line the loader prints (LeRobot may print its own lines)
#: variables passed on to the loader from this process's environment (nothing else: no keys)
PASSED_ENV = ("PATH", "HOME", "LANG", "LC_ALL", "LC_CTYPE", "TMPDIR", "TZ")

#: The loader: argv[1] the dataset folder, argv[2] the repo id; prints MARK and a JSON object.
LOADER = r"""
import json
import sys

import lerobot
from lerobot.datasets.lerobot_dataset import LeRobotDataset

root, repo_id = sys.argv[1], sys.argv[2]
ds = LeRobotDataset(repo_id=repo_id, root=root)
n = len(ds)
if n == 0:
    raise SystemExit("LeRobotDataset holds no frame")
first, last = ds[0], ds[n - 1]


def shapes(item):
    return {k: list(v.shape) for k, v in item.items() if hasattr(v, "shape")}


print("REGEN-LEROBOT-CHECK " + json.dumps({
    "lerobot": lerobot.__version__,
    "frames": n,
    "rows": len(ds.hf_dataset),
    "episodes": ds.num_episodes,
    "fps": ds.fps,
    "features": list(ds.features),
    "first": shapes(first),
    "last": shapes(last),
    "last_index": int(last["index"]),
    "task": first["task"],
}), flush=True)
"""


def lerobot_venv() -> Path:
    """LeRobot's virtual environment: REGEN_LEROBOT_VENV, else ``.venv-lerobot`` of the checkout."""
    env = os.environ.get("REGEN_LEROBOT_VENV")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[4] / ".venv-lerobot"


def lerobot_python() -> Path:
    """The python of :func:`lerobot_venv`; ConfigError saying how to get it."""
    venv = lerobot_venv()
    exe = venv / "bin" / "python"
    if not exe.is_file():
        raise ConfigError(f"LeRobot's loader is not installed ({exe} is missing): run WITH_LEROBOT=1 bash setup.sh, "
                          "which installs lerobot 0.4.4 into .venv-lerobot beside the checkout, or point REGEN_LEROBOT_VENV at "
                          "a virtual environment that has it (docs/dataset.md, 'Manipulation episodes')")
    return exe


def _env(cache: str) -> dict[str, str]:
    env = {k: os.environ[k] for k in PASSED_ENV if k in os.environ}
    env.update(HF_HUB_OFFLINE="1", HF_DATASETS_OFFLINE="1", HF_HOME=cache, TQDM_DISABLE="1")
    return env


def _tail(text: str, lines: int = 8) -> str:
    return "\n".join(text.strip().splitlines()[-lines:]) or "no output"


def check_lerobot(dataset_dir: Path, repo_id: str = DEFAULT_REPO_ID, *, timeout: float = TIMEOUT) -> dict[str, Any]:
    """Open ``dataset_dir`` with LeRobotDataset in LeRobot's own environment: ``lerobot`` (its
    version), ``frames`` (``len(ds)``), ``rows`` (the rows its data files gave), ``episodes``,
    ``fps``, ``features`` (names), ``first`` and ``last`` (each tensor's shape in ``ds[0]`` and
    ``ds[len - 1]``), ``last_index`` and ``task`` (``ds[0]["task"]``). ConfigError when the
    environment is missing; LeRobotCheckError, with the end of the loader's stderr, when it fails."""
    root = Path(dataset_dir).absolute()
    exe = lerobot_python()
    with tempfile.TemporaryDirectory(prefix="regen-lerobot-") as cache:
        try:
            done = subprocess.run([str(exe), "-I", "-c", LOADER, str(root), repo_id], capture_output=True,
                                  text=True, errors="replace", timeout=timeout, cwd=cache, env=_env(cache), check=False)
        except subprocess.TimeoutExpired:
            raise LeRobotCheckError(f"LeRobot's loader did not finish reading {root} in {timeout:g} s") from None
    if done.returncode != 0:
        raise LeRobotCheckError(f"LeRobot's LeRobotDataset could not read {root} (exit {done.returncode}; "
                                f"the loader ran with {exe}). Its stderr ends:\n{_tail(done.stderr)}")
    lines = [line for line in done.stdout.splitlines() if line.startswith(MARK)]
    try:
        result = json.loads(lines[-1][len(MARK):])
    except (IndexError, ValueError):
        raise LeRobotCheckError(f"LeRobot's loader gave no readable result for {root} (the loader ran with "
                                f"{exe}; is it the environment setup.sh builds?). Its output ends:\n"
                                f"{_tail(done.stdout + done.stderr)}") from None
    if not isinstance(result, dict):
        raise LeRobotCheckError(f"LeRobot's loader gave {type(result).__name__}, not an object, for {root}")
    return result


def agrees(result: dict[str, Any], written: dict[str, Any]) -> list[str]:
    """Where what LeRobot read (:func:`check_lerobot`) differs from what was written
    (:func:`~regen.manipulation.export.lerobot.write_lerobot`'s summary); empty when it agrees."""
    bad = []
    for key in ("frames", "rows", "episodes", "fps"):
        want = written["frames"] if key == "rows" else written.get(key)
        if result.get(key) != want:
            bad.append(f"{key} {result.get(key)} (written: {want})")
    if result.get("last_index") != written.get("frames", 0) - 1:
        bad.append(f"the last item's index {result.get('last_index')} (written: {written.get('frames', 0) - 1})")
    tasks = written.get("tasks") or []
    if tasks and result.get("task") != tasks[0]:
        bad.append(f"the first item's task {result.get('task')!r} (written: {tasks[0]!r})")
    return bad


def check_written(out: Path, written: dict[str, Any], repo_id: str = DEFAULT_REPO_ID) -> dict[str, Any]:
    """After writing: LeRobot's loader over ``out`` where its environment is installed. The
    outcome: ``checked`` (whether it ran), ``note`` (one line saying what was checked, or why
    not) and, when it ran, ``lerobot`` (what :func:`check_lerobot` returned). LeRobotCheckError
    when the loader fails or reads other episodes, frames or fps than ``written`` holds."""
    venv = lerobot_venv()
    if not (venv / "bin" / "python").is_file():
        named = os.environ.get("REGEN_LEROBOT_VENV")
        why = f"{venv} (REGEN_LEROBOT_VENV) not found: setup.sh creates .venv-lerobot" if named else \
            f"{venv} not found: WITH_LEROBOT=1 bash setup.sh creates it"
        return {"checked": False, "note": f"not checked with LeRobot's loader: {why}"}
    try:
        result = check_lerobot(out, repo_id)
    except LeRobotCheckError as exc:
        raise LeRobotCheckError(f"the LeRobot dataset was written at {out}, but {exc}") from None
    bad = agrees(result, written)
    if bad:
        raise LeRobotCheckError(f"the LeRobot dataset was written at {out}, but LeRobot {result.get('lerobot')}'s "
                                f"LeRobotDataset reads other values: {'; '.join(bad)}")
    return {"checked": True, "lerobot": result,
            "note": f"checked with LeRobot {result.get('lerobot')}'s LeRobotDataset: {result['episodes']} "
                    f"episodes, {result['frames']} frames at {result['fps']} fps"}


__all__ = ["DEFAULT_REPO_ID", "LOADER", "LeRobotCheckError", "agrees", "check_lerobot", "check_written",
           "lerobot_python", "lerobot_venv"]
