"""``regen import``: an OpenSCENARIO file becomes a scenario the embedded simulator runs and
verifies. A hand-written file (tests/data/xosc, written from the standard, schema-valid) replays
with its pedestrian starting on the ego's distance; files the exporter wrote come back to the
same verdict with the same trajectories (the exporter writes a vertex every step); what the
importer does not read is named, never dropped; ``regen augment`` runs on an imported scene."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("scenic")

from regen.cli import app  # noqa: E402
from regen.core.trace import Trace  # noqa: E402
from regen.errors import ConfigError  # noqa: E402

DATA = Path(__file__).parents[2] / "data" / "xosc"
HAND = DATA / "pedestrian_crossing.xosc"
TOLERANCE = 0.01  # [m] round trip: the exporter writes a trajectory vertex every simulation step


def _import(file: Path, out: Path):
    from regen.pipeline.imports import import_file

    return import_file(file, out, pictures=False).outcomes[0]


def _trace(folder: Path) -> Trace:
    return Trace.model_validate_json((folder / "trace.json").read_text())


def _errors(a: Trace, b: Trace) -> dict[str, float]:
    out = {}
    for name, ta in a.actors.items():
        tb = b.actors[name]
        n = min(len(ta.x), len(tb.x))
        out[name] = float(np.hypot(np.subtract(ta.x[:n], tb.x[:n]), np.subtract(ta.y[:n], tb.y[:n])).max())
    return out


def test_the_hand_written_file_is_schema_valid_and_imports_with_its_storyboard():
    from regen.driving.interop.importing import import_xosc
    from regen.driving.interop.openscenario import validate_xosc

    assert validate_xosc(HAND) == []
    sc = import_xosc(HAND)
    board = sc.behavior.params["imported"]
    (walker,) = board["actors"]
    assert walker["asset"] == "adult" and walker["trigger"][0] == "near" and walker["trigger"][6] == 40.0
    assert sc.behavior.params["recorded"]["detected"] == "stop_abruptly"
    stages = [c["state"] for st in sc.fsm.model_dump()["stages"] for c in st["conditions"]]
    assert stages.index("moving_off") < stages.index("braking")  # the cause before the ego's reaction
    assert any("not beside the file" in n for n in board["notes"])  # the map was recognised by its name


def test_the_hand_written_file_replays_the_pedestrian_starting_on_the_egos_distance(tmp_path):
    out = _import(HAND, tmp_path / "run")
    assert out.verdict.status == "verified", out.verdict.reason
    tr = _trace(out.path)
    ego, walker = tr.actors["ego"], tr.actors["walker"]
    gap = np.hypot(np.subtract(ego.x, -100.0), np.subtract(ego.y, -8.0))
    k_near = int(np.argmax(gap < 40.0))  # the first step the condition holds
    moved = np.hypot(np.subtract(walker.x, walker.x[0]), np.subtract(walker.y, walker.y[0]))
    assert moved[: k_near + 1].max() < 1e-6  # it waits for the ego ...
    assert moved[k_near + 10] > 0.2 and moved[-1] > 5.0  # ... then walks across
    assert max(np.diff(ego.speed)) < 0.01 and min(np.diff(ego.speed)) < -0.5  # the ego only brakes
    assert ego.speed[-1] < 0.1


# an approach; an offset trigger; a wrong-way car that fires while the ego brakes; a door that opens
@pytest.mark.parametrize("key,i", [("stop_abruptly", 0), ("slow_down", 2), ("stop_abruptly", 6), ("stop_abruptly", 3)])
def test_an_exported_file_imports_back_to_the_same_verdict_and_trajectories(chain_result, tmp_path, key, i):
    first = chain_result(key, i)
    assert first.verdict.feasible
    copy = tmp_path / "exported"
    shutil.copytree(first.path, copy)
    back = _import(copy / "scenario.xosc", tmp_path / "back")
    assert back.verdict.status == first.verdict.status, back.verdict.reason
    a, b = _trace(first.path), _trace(back.path)
    errors = _errors(a, b)
    assert max(errors.values()) < TOLERANCE, errors
    for name, track in a.actors.items():  # doors, sirens, lights switch at the same steps
        for key in ("door", "siren", "light_state"):
            if key in track.states:
                assert b.actors[name].states[key] == track.states[key], (name, key)


def test_what_it_does_not_read_is_named(tmp_path):
    from regen.driving.interop.importing import import_xosc

    text = HAND.read_text()
    lane = text.replace('<WorldPosition x="-100.0" y="-8.0" z="0.0" h="1.5708"/>',
                        '<LanePosition roadId="0" laneId="-1" offset="0" s="50"/>')
    (tmp_path / "lane.xosc").write_text(lane)
    with pytest.raises(ConfigError, match="LanePosition"):
        import_xosc(tmp_path / "lane.xosc")
    env = text.replace("<Actions>", "<Actions><GlobalAction><EnvironmentAction/></GlobalAction>", 1)
    (tmp_path / "env.xosc").write_text(env)
    with pytest.raises(ConfigError, match="EnvironmentAction"):
        import_xosc(tmp_path / "env.xosc")
    (tmp_path / "other.xodr").write_text("<OpenDRIVE/>")
    (tmp_path / "map.xosc").write_text(text.replace("straight.xodr", "other.xodr"))
    with pytest.raises(ConfigError, match="not one of the project's generated maps"):
        import_xosc(tmp_path / "map.xosc")
    (tmp_path / "egos.xosc").write_text(text.replace('name="walker"', 'name="ego"').replace(
        'entityRef="walker"', 'entityRef="ego"'))
    with pytest.raises(ConfigError, match="2 ego entities"):
        import_xosc(tmp_path / "egos.xosc")


def test_the_command_imports_resumes_and_says_what_is_wrong(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["import", str(HAND), "--out", str(tmp_path / "run"), "--no-pictures"],
                        env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "verified" in res.output and "starts moving" in res.output
    assert "note: " in res.output  # the domain's import notes (the map it was read on)
    folder = tmp_path / "run" / "scenarios" / "01-pedestrian-crossing"
    stamp = (folder / "verdict.json").stat().st_mtime_ns
    again = runner.invoke(app, ["import", str(HAND), "--out", str(tmp_path / "run"), "--no-pictures"])
    assert again.exit_code == 0 and (folder / "verdict.json").stat().st_mtime_ns == stamp  # resumed, not redone
    assert (tmp_path / "run" / "report.html").is_file() and (folder / "scenario.xosc").is_file()
    bad = runner.invoke(app, ["import", str(tmp_path / "nothing.xosc"), "--out", str(tmp_path / "x")])
    assert bad.exit_code != 0 and "no such file" in bad.output
    txt = tmp_path / "a.txt"
    txt.write_text("x")
    wrong = runner.invoke(app, ["import", str(txt), "--out", str(tmp_path / "y")])
    assert wrong.exit_code != 0 and ".xosc" in wrong.output


@pytest.mark.slow
def test_augment_adds_a_cause_around_the_imported_storyboard(tmp_path, monkeypatch):
    from regen.llm import registry
    from regen.llm.testing import QueuedProvider

    out = _import(HAND, tmp_path / "run")
    assert out.verdict.feasible
    provider = QueuedProvider([{"add": ["a cyclist rides ahead"], "irrelevant": []}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    res = CliRunner().invoke(app, ["augment", str(out.path), "--llm", "queued:test", "--no-judge", "--no-pictures",
                                   "--out", str(tmp_path / "aug")], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    record = json.loads((tmp_path / "aug" / f"{out.path.name}-augment" / "augment.json").read_text())
    (added,) = record["additions"]
    assert added["holds"], added
    sc = json.loads((Path(added["folder"]) / "scenario.json").read_text())["scenario"]
    assets = {e["name"]: e["asset"] for e in sc["entities"]}
    assert assets["walker"] == "adult" and "bicycle" in assets.values()  # kept, and added around it
    walker = _trace(Path(added["folder"])).actors["walker"]
    assert np.hypot(walker.x[-1] - walker.x[0], walker.y[-1] - walker.y[0]) > 5.0  # it still crosses


def test_an_exported_light_comes_back_switching_at_the_same_steps(tmp_path):
    from driving_chains import chain

    from regen.pipeline.stages import run_path

    light = chain("stop_abruptly", "the traffic light ahead turns red", ("traffic_light", {"light_state": ["turns_red"]}))
    first = run_path(light, tmp_path / "first", pictures=False)
    assert first.verdict.feasible
    back = _import(tmp_path / "first" / "scenario.xosc", tmp_path / "back")
    assert back.verdict.status == first.verdict.status, back.verdict.reason
    a = _trace(first.path).actors["traffic_light1"].states["light_state"]
    b = _trace(back.path).actors["traffic_light1"].states["light_state"]
    assert a == b and a[0] == "green" and a[-1] == "red"


def test_whatif_adds_a_cause_to_an_imported_scenario_and_its_actors_stay(tmp_path):
    out = _import(HAND, tmp_path / "run")
    res = CliRunner().invoke(app, ["whatif", str(out.path), "--add", "a truck is parked at the roadside ahead",
                                   "--no-pictures", "--no-judge"], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    (folder,) = (tmp_path / "run" / "whatif").glob("*-whatif-*")
    record = json.loads((folder / "whatif.json").read_text())
    assert record["status"] == "verified", record["reason"]  # the file's motion is not judged by words
    sc = json.loads((folder / "scenario.json").read_text())["scenario"]
    assert {e["asset"] for e in sc["entities"]} >= {"adult", "truck"}
    stages = [c["state"] for st in sc["fsm"]["stages"] for c in st["conditions"]]
    assert stages.index("moving_off") < stages.index("braking")  # the imported cause still before the reaction
