"""The exported Scenic programs run where their docstring says: a scenario folder copied
elsewhere (the original gone) runs to its end with exactly the command its ``scenario.scenic``
documents, the map found beside the program (``localPath``), not in the user's cache; the CARLA
program names its map and command the same way."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from driving_chains import FEASIBLE

pytest.importorskip("scenic")

CHILD = FEASIBLE["stop_abruptly"][0]  # a child runs across the road


def _scenic_executable() -> str:
    beside = Path(sys.executable).parent / "scenic"
    found = str(beside) if beside.is_file() else shutil.which("scenic")
    if found is None:
        pytest.fail("the scenic command is not installed beside this Python")
    return found


@pytest.fixture(scope="module")
def moved(tmp_path_factory) -> Path:
    """A scenario folder made by the pipeline, copied to another place, the original removed."""
    from regen.pipeline.stages import run_path

    made = tmp_path_factory.mktemp("made") / "01-child"
    assert run_path(CHILD, made, pictures=False).verdict.feasible
    target = tmp_path_factory.mktemp("elsewhere") / "copied scenario"  # a space in the path too
    shutil.copytree(made, target)
    shutil.rmtree(made)
    return target


@pytest.mark.slow
def test_a_copied_scenario_folder_runs_to_its_end_with_the_documented_command(moved):
    from regen.driving.interop.scenic import run_command
    from regen.paths import cache_dir

    program = (moved / "scenario.scenic").read_text(encoding="utf-8")
    assert "param map = localPath('straight-v2.xodr')" in program and (moved / "straight-v2.xodr").is_file()
    assert str(cache_dir()) not in program  # nothing of the user's machine in the file
    command = run_command(program)
    assert command == "scenic --2d --simulate --count 1 --time 160 scenario.scenic"
    argv = shlex.split(command)
    argv[0] = _scenic_executable()
    res = subprocess.run(argv, cwd=moved, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "MPLBACKEND": "Agg"})
    assert res.returncode == 0, res.stderr[-2000:]
    assert "Ran simulation" in res.stdout, res.stdout[-2000:]


def test_the_carla_program_names_its_map_beside_it_and_a_command_that_ends(moved):
    from regen.driving.interop.scenic import run_command

    program = (moved / "scenario.carla.scenic").read_text(encoding="utf-8")
    assert "param map = localPath('straight-v2.xodr')" in program
    assert "param carla_map = 'straight-v2'" in program
    assert run_command(program) == "scenic --2d --simulate --count 1 --time 160 scenario.carla.scenic"


def test_the_export_lists_the_map_it_copied_and_keeps_a_copy_already_there(tmp_path, moved):
    import json

    from regen.core.scenario import Scenario
    from regen.driving.interop.scenic import export_scenic
    from regen.driving.world.maps import ensure_map

    listed = json.loads((moved / "files.json").read_text())
    assert listed["xodr"] == "straight-v2.xodr"
    sc = Scenario.model_validate(json.loads((moved / "scenario.json").read_text())["scenario"])
    (tmp_path / "straight-v2.xodr").write_text("kept")  # e.g. the OpenSCENARIO export's, with signals
    files = export_scenic(sc, tmp_path)
    assert files["xodr"].read_text() == "kept"
    fresh = export_scenic(sc, tmp_path / "fresh")
    assert fresh["xodr"].read_bytes() == ensure_map("straight").read_bytes()
