"""The exported maps and scenarios pass the standard's own checkers: the ASAM Quality Checker
bundles for OpenDRIVE and OpenSCENARIO XML (installed by setup.sh into .venv-qc), over the
first hand-written chain of every ego template and chains whose storyboard switches a siren, a
door and a traffic light's signal (the map's copy then holds the signal). Schema validity is checked, not skipped, so the
semantic checks that apply to the declared version run too."""

from __future__ import annotations

import hashlib
import os

import pytest
from driving_chains import FEASIBLE, chain

from regen.driving.interop.qc import check_file, parse_result, program, qc_venv

pytest.importorskip("scenic")


def _need_checkers() -> None:
    try:
        program(".xodr")
        program(".xosc")
    except Exception as exc:
        if os.environ.get("CI"):
            raise  # CI installs them: missing checkers fail the suite there
        pytest.skip(f"ASAM checkers not installed in {qc_venv()}: {exc}")


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    _need_checkers()
    from regen.pipeline.stages import run_path

    light = chain("stop_abruptly", "the traffic light ahead turns red", ("traffic_light", {"light_state": ["turns_red"]}))
    chains = {tid: paths[0] for tid, paths in FEASIBLE.items()}
    # with state changes in the storyboard: a siren on, a door that opens, a light's signal
    chains.update({"siren": FEASIBLE["stop_abruptly"][1], "door": FEASIBLE["stop_abruptly"][3], "light": light})
    files = {}
    for tid, path in chains.items():
        folder = tmp_path_factory.mktemp(tid)
        assert run_path(path, folder, pictures=False).verdict.feasible
        files[tid] = sorted(folder.glob("*.xodr")) + sorted(folder.glob("*.xosc"))
    return files


@pytest.mark.slow
def test_every_exported_map_and_scenario_passes_the_asam_checkers_without_error(exports):
    maps_checked, names = set(), set()
    for tid, files in exports.items():
        assert {f.suffix for f in files} == {".xodr", ".xosc"}, tid
        for f in files:
            digest = hashlib.sha256(f.read_bytes()).hexdigest()
            if f.suffix == ".xodr" and digest in maps_checked:  # the same map copied beside each scenario
                continue
            maps_checked.add(digest)
            names.add(f.name)
            report = check_file(f)
            assert not report.errors, (tid, report.summary(), [(i.checker, i.where) for i in report.errors])
            assert not report.failed, (tid, report.failed)
            schema = "check_asam_xodr_xml_valid_schema" if f.suffix == ".xodr" else "check_asam_xosc_xml_valid_schema"
            assert schema in report.completed, (tid, report.skipped.get(schema))
    assert {"straight-v2.xodr", "four_way-v2.xodr", "t_junction-v2.xodr"} <= names


def test_a_schema_error_is_read_back_as_an_error(tmp_path):
    result = tmp_path / "r.xqar"
    result.write_text(
        '<?xml version="1.0"?><CheckerResults><CheckerBundle name="xodrBundle">'
        '<Param name="InputFile" value="m.xodr"/>'
        '<Checker status="completed" checkerId="check_asam_xodr_xml_valid_schema" summary="1 issue(s)">'
        '<Issue issueId="0" level="1" description="does not follow its version schema">'
        '<Locations description="Element \'elevationProfile\': Missing child element(s)."/></Issue></Checker>'
        '<Checker status="skipped" checkerId="check_asam_xodr_road_lane_level_true_one_side" summary="Version 1.5.0"/>'
        '</CheckerBundle></CheckerResults>')
    r = parse_result(result)
    assert r.file == "m.xodr" and [i.level for i in r.errors] == ["error"]
    assert "elevationProfile" in r.errors[0].where[0] and "check_asam_xodr_road_lane_level_true_one_side" in r.skipped
