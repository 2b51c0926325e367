"""The reading holes of issue 37 that :mod:`regen.promises.files` and the OpenSCENARIO reader
close, one test (or more) each, through the commands a user runs:

4. tracebacks from ``regen import``: a parameter inside an attribute (declared or not),
   ``scale="abc"``, ``x="nan"``, a road network file ``/proc/self/mem`` (EIO), a map with
   ``<signal s="abc">``.
6. ``eval --fidelity``: a non-UTF-8 file, 100k nested brackets, and a cut-off last line in its
   own ``fidelity.jsonl`` after a kill that made every resume fail.
7. ``--ego-trajectory`` with a CSV field over the csv module's 128 KB limit.
9. a trajectory CSV a spreadsheet saved with a byte-order mark was refused ("has no column t
   (its header: t,x,y)").
10. OpenSCENARIO elements the reader does not read (in ``Init``, a ``Story``, the root's
    ``ParameterDeclarations``) were dropped silently.

Each bad input: exit 2, one line ``error: ...`` naming the file and what to do, no traceback.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from regen.cli import app

sys.path.insert(0, str(Path(__file__).parent))  # the tests folder is not a package
from test_cli_faults import _one_line_error  # noqa: E402

HAND = Path(__file__).parent / "data" / "xosc" / "pedestrian_crossing.xosc"
WALKER_START = '<WorldPosition x="-100.0" y="-8.0" z="0.0" h="1.5708"/>'
TRAJECTORY = """<RoutingAction><FollowTrajectoryAction>
  <TrajectoryRef><Trajectory name="walk" closed="false"><Shape><Polyline>
    <Vertex time="0"><Position><WorldPosition x="-100.0" y="-8.0" z="0" h="1.5708"/></Position></Vertex>
    <Vertex time="8"><Position><WorldPosition x="-100.0" y="4.0" z="0" h="1.5708"/></Position></Vertex>
  </Polyline></Shape></Trajectory></TrajectoryRef>
  <TimeReference><Timing domainAbsoluteRelative="relative" scale="1.0" offset="0.0"/></TimeReference>
  <TrajectoryFollowingMode followingMode="position"/>
</FollowTrajectoryAction></RoutingAction>"""


def _cli(*args: str):
    return CliRunner().invoke(app, list(args), env={"COLUMNS": "300"})


def _xosc(tmp_path: Path, name: str, text: str) -> Path:
    f = tmp_path / f"{name}.xosc"
    f.write_text(text, encoding="utf-8")
    return f


def _import(file: Path, tmp_path: Path):
    return _cli("import", str(file), "--out", str(tmp_path / "run"), "--no-pictures")


def _hand() -> str:
    return HAND.read_text(encoding="utf-8")


def _with_trajectory() -> str:
    """The hand-written file, its pedestrian walking a timed trajectory instead of a speed."""
    text = _hand()
    walk = re.search(r'<Action name="walk">\s*<PrivateAction>(.*?)</PrivateAction>', text, re.S)
    assert walk is not None
    return text.replace(walk.group(1), TRAJECTORY)


# --- 4: regen import, values it cannot read --------------------------------------------------------


@pytest.mark.parametrize("declared", [False, True])
def test_import_a_parameter_inside_an_attribute(tmp_path: Path, declared: bool) -> None:
    text = _hand().replace(WALKER_START, WALKER_START.replace('h="1.5708"', 'h="$heading"'))
    if declared:
        text = text.replace("<ParameterDeclarations/>", '<ParameterDeclarations><ParameterDeclaration '
                            'name="heading" parameterType="double" value="1.5708"/></ParameterDeclarations>')
    f = _xosc(tmp_path, "param", text)
    line = _one_line_error(_import(f, tmp_path), str(f), "h='$heading'", "parameter reference", "docs/interop.md")
    assert ("write its value, '1.5708'" in line) == declared  # what to write instead, when the file says it


def test_import_a_scale_that_is_not_a_number(tmp_path: Path) -> None:
    f = _xosc(tmp_path, "scale", _with_trajectory().replace('scale="1.0"', 'scale="abc"'))
    _one_line_error(_import(f, tmp_path), str(f), "scale='abc'", "<Timing>", "not a number")


def test_import_nan_and_inf(tmp_path: Path) -> None:
    f = _xosc(tmp_path, "nan", _hand().replace(WALKER_START, WALKER_START.replace('x="-100.0"', 'x="nan"'))
              .replace('<DistanceCondition value="40.0"', '<DistanceCondition value="inf"'))
    line = _one_line_error(_import(f, tmp_path), str(f), "x='nan'", "value='inf'", "not a finite number")
    assert "Init of 'walker'" in line and "Event 'walker_starts_crossing'" in line  # where each one is


@pytest.mark.skipif(not Path("/proc/self/mem").exists(), reason="no /proc")
def test_import_a_road_network_file_that_cannot_be_read(tmp_path: Path) -> None:
    f = _xosc(tmp_path, "mem", _hand().replace("straight.xodr", "/proc/self/mem"))
    _one_line_error(_import(f, tmp_path), str(f), "the map", "cannot be read", "reference a generated map")


def test_import_a_road_network_that_is_a_folder(tmp_path: Path) -> None:
    (tmp_path / "maps").mkdir()
    f = _xosc(tmp_path, "folder", _hand().replace("straight.xodr", "maps"))
    _one_line_error(_import(f, tmp_path), str(f), "is a folder", "reference a generated map")


def test_import_a_map_with_a_signal_whose_s_is_not_a_number(tmp_path: Path) -> None:
    from regen.driving.interop.signals import Light, with_signals
    from regen.driving.world.maps import ensure_map

    xodr, _ = with_signals(ensure_map("straight").read_text(encoding="utf-8"), [Light("light1", -100.0, -8.0, 0.0)])
    (tmp_path / "signals.xodr").write_text(re.sub(r'<signal s="[^"]*"', '<signal s="abc"', xodr), encoding="utf-8")
    f = _xosc(tmp_path, "signal", _hand().replace("straight.xodr", "signals.xodr"))
    _one_line_error(_import(f, tmp_path), str(f), "signals.xodr", "s='abc'", "write each <signal>'s s and t")


# --- 10: regen import, elements it does not read ---------------------------------------------------


@pytest.mark.parametrize(("where", "old", "new", "says"), [
    ("Init", "<Actions>", '<Actions><Foo bar="1"/>', "<Foo> in Storyboard/Init/Actions"),
    ("a Story", '<Story name="crossing">', '<Story name="crossing"><Bar/>', "<Bar> in Story 'crossing'"),
    ("the root's parameters", "<ParameterDeclarations/>",
     '<ParameterDeclarations><ParameterDeclaration name="speed" parameterType="double" value="10"/>'
     "</ParameterDeclarations>", "<ParameterDeclaration 'speed'> in ParameterDeclarations"),
    ("an attribute", '<Event name="walker_starts_crossing" priority="override" maximumExecutionCount="1">',
     '<Event name="walker_starts_crossing" priority="override" maximumExecutionCount="3">',
     "maximumExecutionCount='3' of <Event 'walker_starts_crossing'>"),
    ("an Act's stop", "</Act>", '<StopTrigger><ConditionGroup><Condition name="c" delay="0" conditionEdge="none">'
     '<ByValueCondition><SimulationTimeCondition value="5" rule="greaterThan"/></ByValueCondition></Condition>'
     "</ConditionGroup></StopTrigger></Act>", "<ConditionGroup> in Act 'main'/StopTrigger"),
])
def test_import_names_what_it_does_not_read(tmp_path: Path, where: str, old: str, new: str, says: str) -> None:
    text = _hand()
    assert old in text, where
    f = _xosc(tmp_path, "unread", text.replace(old, new, 1))
    _one_line_error(_import(f, tmp_path), str(f), "regen import does not read", says, "docs/interop.md")


def test_import_names_every_problem_in_one_message(tmp_path: Path) -> None:
    text = (_hand().replace("<Actions>", "<Actions><Foo/>", 1)
            .replace('<Story name="crossing">', '<Story name="crossing"><Bar/>')
            .replace('freespace="false" rule="lessThan"', 'freespace="true" rule="lessThan"', 1)
            .replace('<AbsoluteTargetSpeed value="10.0"/>', '<AbsoluteTargetSpeed value="fast"/>'))
    f = _xosc(tmp_path, "many", text)
    _one_line_error(_import(f, tmp_path), str(f), "<Foo>", "<Bar>", "freespace='true'", "value='fast'")


def test_import_reads_the_exporters_attributes_without_naming_them(tmp_path: Path) -> None:
    """What the reader passes over is named only when it could change the replay: the hand-written
    file (performance, axles, bounding-box centres, condition edges, a trajectory's following
    mode) and one walking a trajectory read as before."""
    from regen.driving.interop.xosc_read import read_xosc

    assert len(read_xosc(HAND).events) == 2
    f = _xosc(tmp_path, "trajectory", _with_trajectory())
    (walk,) = [e for e in read_xosc(f).events if e.actor == "walker"]
    assert walk.actions[0].kind == "trajectory" and walk.actions[0].relative


# --- 6: regen eval --fidelity ----------------------------------------------------------------------


def _eval(cases: Path, out: Path):
    return _cli("eval", "--fidelity", str(cases), "--out", str(out))


def test_eval_fidelity_file_that_is_not_utf8(tmp_path: Path) -> None:
    f = tmp_path / "cases.jsonl"
    f.write_bytes(b'{"id": "a"}\n{"id": "caf\xe9"}\n')
    _one_line_error(_eval(f, tmp_path / "out"), str(f), "line 2", "not UTF-8", "save it as UTF-8")


def test_eval_fidelity_file_nested_100k_deep(tmp_path: Path) -> None:
    f = tmp_path / "cases.jsonl"
    f.write_text("[" * 100_000 + "\n")
    _one_line_error(_eval(f, tmp_path / "out"), str(f), "line 1", "nested too deeply", "JSON-lines")


def _case(i: str) -> dict:
    return {"id": i, "domain": "driving", "behavior": "the ego-vehicle stops abruptly while driving forward",
            "ego_template": "stop_abruptly", "cause": f"cause {i}", "entities": [{"any_of": ["sedan"]}],
            "split": "test"}


def _result(i: str) -> dict:
    return {"id": i, "domain": "driving", "split": "test", "status": "verified", "entities_ok": True,
            "states_ok": 0, "states_total": 0, "shown": [], "folder": "", "causal": None}


@pytest.fixture
def ran(monkeypatch) -> list[str]:
    """The ids of the cases that ran (each as a verified result, without a model)."""
    from regen.evaluation import fidelity

    ids: list[str] = []

    def run_case(case, out, *, llm, seed=0):
        ids.append(case.id)
        return fidelity.CaseResult(**_result(case.id))

    monkeypatch.setattr(fidelity, "run_case", run_case)
    return ids


def test_eval_fidelity_resumes_after_a_kill_cut_its_last_line(tmp_path: Path, ran: list[str]) -> None:
    cases = tmp_path / "cases.jsonl"
    cases.write_text("".join(json.dumps(_case(i)) + "\n" for i in "abc"))
    out = tmp_path / "out"
    out.mkdir()
    whole = json.dumps(_result("a")) + "\n"
    (out / "fidelity.jsonl").write_text(whole + json.dumps(_result("b"))[:40])  # killed mid-write
    res = _cli("eval", "--fidelity", str(cases), "--out", str(out))
    assert res.exit_code == 0, (res.output, res.exception)
    assert "dropped its cut-off last line 2" in res.output and "runs again" in res.output
    assert ran == ["b", "c"]  # a was done; b was cut off, so it runs again
    rows = [json.loads(line) for line in (out / "fidelity.jsonl").read_text().splitlines()]
    assert [r["id"] for r in rows] == ["a", "b", "c"]
    again = _cli("eval", "--fidelity", str(cases), "--out", str(out))  # and the next resume is clean
    assert again.exit_code == 0 and "dropped" not in again.output and ran == ["b", "c"]


def test_eval_fidelity_a_broken_line_before_the_last_is_one_line(tmp_path: Path, ran: list[str]) -> None:
    cases = tmp_path / "cases.jsonl"
    cases.write_text(json.dumps(_case("a")) + "\n")
    out = tmp_path / "out"
    out.mkdir()
    results = out / "fidelity.jsonl"
    results.write_text('{"id": "a", "dom\n' + json.dumps(_result("b")) + "\n")
    _one_line_error(_eval(cases, out), str(results), "line 1", "not valid JSON", "delete the line")
    results.write_text(json.dumps(["not", "a", "result"]) + "\n")
    _one_line_error(_eval(cases, out), str(results), "line 1", "not a case result")
    assert ran == []


# --- 7 and 9: --ego-trajectory ---------------------------------------------------------------------


def _stop_rows() -> str:
    """10 m/s, braking from t = 2 s to a stop, 10 Hz: a stop the detector knows."""
    rows, x, v = [], 0.0, 10.0
    for k in range(60):
        rows.append(f"{k / 10:.1f},{x:.3f},0")
        if k >= 20:
            v = max(0.0, v - 0.6)
        x += v * 0.1
    return "\n".join(rows) + "\n"


def test_ego_trajectory_with_a_field_over_the_csv_limit(tmp_path: Path) -> None:
    f = tmp_path / "ego.csv"
    f.write_text("t,x,y\n" + _stop_rows() + "6.0," + "1" * 200_000 + ",0\n")
    _one_line_error(_cli("generate", "--domain", "driving", "--ego-trajectory", str(f), "--out",
                         str(tmp_path / "run"), "--log", "quiet"),
                    str(f), "row 62", "a field longer than 131072 characters", "give a CSV file")


def test_ego_trajectory_saved_with_a_byte_order_mark_is_read(tmp_path: Path) -> None:
    from regen.driving.world.recorded import read_trajectory
    from regen.driving.world.replay import recording

    f = tmp_path / "ego.csv"
    f.write_bytes(b"\xef\xbb\xbf" + ("t,x,y\r\n" + _stop_rows().replace("\n", "\r\n")).encode())
    assert len(read_trajectory(f).t) == 60
    rec, detection = recording(f)  # what --ego-trajectory runs
    assert detection.behavior == "stop_abruptly" and rec.detected == "stop_abruptly"


# --- found by the property test (tests/promises/test_reading_properties.py) ------------------------


@pytest.mark.parametrize(("rows", "says"), [
    ("0,0,0\n1e-320,0,0\n", "samples must be at least 0.001 s apart"),  # was an OverflowError
    ("0,0,0\n1e9,0,0\n", "cut the recording to at most 600 s"),  # was a grid of 1e10 samples
])
def test_ego_trajectory_sampled_absurdly(tmp_path: Path, rows: str, says: str) -> None:
    f = tmp_path / "ego.csv"
    f.write_text("t,x,y\n" + rows)
    _one_line_error(_cli("generate", "--domain", "driving", "--ego-trajectory", str(f), "--out",
                         str(tmp_path / "run"), "--log", "quiet"), str(f), says)


def test_import_a_stop_trigger_before_the_start(tmp_path: Path) -> None:
    f = _xosc(tmp_path, "stop", _hand().replace('<SimulationTimeCondition value="12" rule="greaterThan"/>',
                                                '<SimulationTimeCondition value="-5" rule="greaterThan"/>'))
    _one_line_error(_import(f, tmp_path), str(f), "<StopTrigger> ends the scenario at -5 s", "plays at least 1 s")
