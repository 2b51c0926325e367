"""LeRobot's own loader in its own environment (.venv-lerobot): where it is looked for, what is
said when it is missing, what it is run with (a fixed script, isolated, offline, no secrets), and
how a failing loader is reported. The loader itself over a written dataset:
test_lerobot_export.py."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from regen.errors import ConfigError
from regen.manipulation.export import lerobot_check as lc
from regen.manipulation.export.lerobot_check import LeRobotCheckError, check_lerobot, check_written

WRITTEN = {"episodes": 2, "frames": 206, "fps": 12, "tasks": ["open the door"]}
READ = {"lerobot": "0.4.4", "frames": 206, "rows": 206, "episodes": 2, "fps": 12, "features": ["action"],
        "first": {"action": [9]}, "last": {"action": [9]}, "last_index": 205, "task": "open the door"}


def _stand_in(tmp_path: Path, stdout: str = "", stderr: str = "", code: int = 0) -> Path:
    """A virtual environment whose python records its arguments and environment, then prints
    ``stdout`` and ``stderr`` and exits with ``code``."""
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    exe = venv / "bin" / "python"
    exe.write_text(f"#!{sys.executable}\n"
                   "import json, os, sys\n"
                   f"open({str(tmp_path / 'called.json')!r}, 'w').write(json.dumps("
                   "{'argv': sys.argv[1:], 'env': dict(os.environ), 'cwd': os.getcwd()}))\n"
                   f"sys.stdout.write({stdout!r}); sys.stderr.write({stderr!r}); sys.exit({code})\n")
    exe.chmod(0o755)
    return venv


def test_the_environment_is_beside_the_checkout_unless_named(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("REGEN_LEROBOT_VENV", raising=False)
    assert lc.lerobot_venv() == Path(__file__).resolve().parents[2] / ".venv-lerobot"
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(tmp_path / "mine"))
    assert lc.lerobot_venv() == tmp_path / "mine"


def test_a_missing_environment_says_what_to_do(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(tmp_path / "none"))
    with pytest.raises(ConfigError) as err:
        check_lerobot(tmp_path)
    msg = str(err.value)
    assert str(tmp_path / "none" / "bin" / "python") in msg and "is missing" in msg
    assert "run WITH_LEROBOT=1 bash setup.sh" in msg and ".venv-lerobot" in msg and "REGEN_LEROBOT_VENV" in msg
    got = check_written(tmp_path, WRITTEN)  # after writing: a note, not an error
    assert got["checked"] is False
    assert got["note"] == (f"not checked with LeRobot's loader: {tmp_path / 'none'} (REGEN_LEROBOT_VENV) not "
                           "found: setup.sh creates .venv-lerobot")


def test_the_fixed_loader_runs_isolated_offline_and_without_secrets(monkeypatch: pytest.MonkeyPatch,
                                                                     tmp_path: Path) -> None:
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(_stand_in(tmp_path, stdout="a line of LeRobot's\n"
                                                                           + lc.MARK + json.dumps(READ) + "\n")))
    monkeypatch.setenv("OPENAI_API_KEY", "sk-not-for-the-loader")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    (tmp_path / "ds").mkdir()
    assert check_lerobot(tmp_path / "ds", repo_id="regen/open-door") == READ
    called = json.loads((tmp_path / "called.json").read_text())
    assert called["argv"] == ["-I", "-c", lc.LOADER, str(tmp_path / "ds"), "regen/open-door"]
    env = called["env"]
    assert env["HF_HUB_OFFLINE"] == "1" and env["HF_DATASETS_OFFLINE"] == "1"
    assert env["HF_HOME"] == called["cwd"] != str(tmp_path / "ds")  # a temporary folder, removed after
    assert not Path(called["cwd"]).exists()
    assert set(env) <= set(lc.PASSED_ENV) | {"HF_HUB_OFFLINE", "HF_DATASETS_OFFLINE", "HF_HOME", "TQDM_DISABLE"}
    assert "OPENAI_API_KEY" not in env and "PYTHONPATH" not in env
    # the loader imports nothing but json, sys and lerobot (the environment holds no regen)
    imports = {line.split()[1].split(".")[0] for line in lc.LOADER.splitlines()
               if line.startswith(("import ", "from "))}
    assert imports == {"json", "sys", "lerobot"}
    assert check_written(tmp_path / "ds", WRITTEN)["note"] == (
        "checked with LeRobot 0.4.4's LeRobotDataset: 2 episodes, 206 frames at 12 fps")


def test_a_failing_loader_is_an_error_with_its_stderr(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    stderr = "Traceback (most recent call last):\n" + "".join(f"  line {k}\n" for k in range(20)) + \
        "KeyError: 'observation.state'\n"
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(_stand_in(tmp_path, stderr=stderr, code=1)))
    with pytest.raises(LeRobotCheckError) as err:
        check_lerobot(tmp_path)
    msg = str(err.value)
    assert f"LeRobotDataset could not read {tmp_path} (exit 1" in msg
    assert msg.endswith("  line 19\nKeyError: 'observation.state'") and "  line 5\n" not in msg  # the tail
    with pytest.raises(LeRobotCheckError, match=f"was written at {tmp_path}, but LeRobot's LeRobotDataset"):
        check_written(tmp_path, WRITTEN)


def test_a_loader_without_a_result_or_with_another_one_is_an_error(monkeypatch: pytest.MonkeyPatch,
                                                                   tmp_path: Path) -> None:
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(_stand_in(tmp_path, stdout=lc.MARK + "{not json\n")))
    with pytest.raises(LeRobotCheckError, match="gave no readable result"):
        check_lerobot(tmp_path)
    assert lc.agrees(READ, WRITTEN) == []
    assert lc.agrees({**READ, "rows": 200, "task": "other"}, WRITTEN) == [
        "rows 200 (written: 206)", "the first item's task 'other' (written: 'open the door')"]
    monkeypatch.setenv("REGEN_LEROBOT_VENV", str(_stand_in(tmp_path / "b", stdout=lc.MARK + json.dumps(
        {**READ, "frames": 205}) + "\n")))
    with pytest.raises(LeRobotCheckError, match=r"reads other values: frames 205 \(written: 206\)"):
        check_written(tmp_path, WRITTEN)


def test_lerobot_reports_a_broken_info_json(lerobot_python: Path, tmp_path: Path) -> None:
    """The real loader (LeRobot's environment) over a dataset whose meta/info.json is cut short:
    an error that ends with LeRobot's own exception."""
    (tmp_path / "ds" / "meta").mkdir(parents=True)
    (tmp_path / "ds" / "meta" / "info.json").write_text('{"codebase_version": "v3.0", "fps": ')
    with pytest.raises(LeRobotCheckError) as err:
        check_lerobot(tmp_path / "ds")
    msg = str(err.value)
    assert f"LeRobotDataset could not read {tmp_path / 'ds'} (exit 1; the loader ran with {lerobot_python})" in msg
    assert "json.decoder.JSONDecodeError: Expecting value" in msg.splitlines()[-1]
