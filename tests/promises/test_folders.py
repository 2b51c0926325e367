"""Choosing an output folder: a file in its place, a folder outside a run, what a command did not
write: one line that says what to give."""

from __future__ import annotations

from pathlib import Path

import pytest

from regen.errors import ConfigError, RunError
from regen.promises.folders import (
    beside_run,
    foreign_error,
    is_temp_of,
    listing,
    out_folder,
    output_folder,
    run_of,
)

WHERE = {"manifest": "run.json", "scenarios": "scenarios"}


def test_an_empty_option_is_refused() -> None:
    with pytest.raises(ConfigError, match="--out is empty"):
        out_folder("  ")
    assert out_folder("runs/x") == Path("runs/x")


def test_output_folder_is_made_or_refused_on_one_line(tmp_path: Path) -> None:
    assert output_folder(tmp_path / "a" / "b").is_dir()
    a_file = tmp_path / "f.txt"
    a_file.write_text("mine")
    with pytest.raises(ConfigError, match=r"--out .*f\.txt is a file; give a folder for x"):
        output_folder(a_file, give="a folder for x")
    with pytest.raises(RunError, match="lies under a file; give a folder path"):
        output_folder(a_file / "sub", error=RunError)
    with pytest.raises(ConfigError, match="is a file; move it aside or give --out FOLDER"):
        output_folder(a_file, given=False, what="the what-if folder")
    assert a_file.read_text() == "mine"


def test_a_default_beside_a_run_needs_a_run(tmp_path: Path) -> None:
    scene = tmp_path / "run" / "scenarios" / "01-x"
    scene.mkdir(parents=True)
    with pytest.raises(ConfigError, match="not a scenario folder of a run.*--out FOLDER"):
        beside_run(scene, "whatif", **WHERE)
    (tmp_path / "run" / "run.json").write_text("{}")
    assert run_of(scene, **WHERE) == tmp_path / "run"
    assert beside_run(scene, "whatif", **WHERE) == tmp_path / "run" / "whatif"
    assert run_of(scene / "..", **WHERE) is None  # 'scenarios' is no scenario folder
    other = tmp_path / "elsewhere" / "scene"
    other.mkdir(parents=True)
    assert run_of(other, **WHERE) is None


def test_what_a_command_did_not_write_is_named() -> None:
    assert is_temp_of(".run.json.a1b2.tmp", ["run.json"]) and not is_temp_of("run.json.tmp", ["run.json"])
    assert listing([str(i) for i in range(8)]) == "0, 1, 2, 3, 4, 5 and 2 more"
    err = foreign_error(Path("RUN"), ["notes.txt"], doing="--fresh", writer="a run", error=RunError)
    assert isinstance(err, RunError) and "RUN holds what a run does not write (notes.txt)" in str(err)
    assert "nothing was removed" in str(err)
