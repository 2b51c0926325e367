"""The report's "Behavior tests" section: counts, collision rates per behavior and per cause,
minimum time to collision, a GIF of each failure, and broken tests.json files named, not raised.

The slow tests run real policies (Scenic's Newtonian simulator) on the hand-written chain in
which a child runs across the road: constant-speed hits the child, idm yields without braking
as hard as the FSM expects (a failure without a collision), aeb passes.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from urllib.parse import unquote

import pytest
from PIL import Image

from regen.core.io import write_json
from regen.report import load_run, write_report
from regen.runfolder import RunFolder, read_tests

CHILD = "01-child-crosses"
DRIVING_TESTS = Path(__file__).resolve().parents[1] / "driving"


def _row(html: str, folder: str) -> str:
    """The summary table row of one policy's tests."""
    start = html.index(f'id="tests-{folder}"')
    return html[start:html.index("</tr>", start)]


def _cell(row: str, cls: str) -> str:
    m = re.search(rf'class="num {cls}">(.*?)</td>', row, re.S)
    assert m, f"no {cls} cell in {row}"
    return re.sub(r"<[^>]+>", "", m.group(1)).strip()


def _tests_section(html: str) -> str:
    start = html.index('<h2 id="tests">')
    return html[start:html.index('<h2 id="', start + 1)]  # up to the next section


# --- real policies on a verified scenario (slow) -------------------------------------------------


@pytest.fixture(scope="module")
def tested_run(tmp_path_factory):
    """A run folder with the verified child-crossing scenario, tested with constant-speed, idm
    and aeb, failures kept (trace + GIF) and report.html rendered."""
    pytest.importorskip("scenic")
    sys.path.insert(0, str(DRIVING_TESTS))  # the tests folder is not a package
    from driving_chains import FEASIBLE

    from regen.driving.testing.harness import DrivingHarness
    from regen.harness.cli import default_out
    from regen.harness.junit import write_report as write_tests
    from regen.harness.pictures import keep_failures
    from regen.harness.suite import run_tests
    from regen.pipeline import run_path

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("REGEN_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        run = tmp_path_factory.mktemp("run")
        out = run_path(FEASIBLE["stop_abruptly"][0], run / RunFolder.SCENARIOS / CHILD, pictures=False)
        assert out.verdict.feasible, out.verdict.reason
        reports = {}
        for policy in ("constant-speed", "idm", "aeb"):
            dest = default_out(run, policy)
            reports[policy] = run_tests(run, policy, on_episode=keep_failures(dest, DrivingHarness(), policy=policy))
            write_tests(reports[policy], dest)
        report = write_report(run)
        yield run, report.read_text(encoding="utf-8"), reports


@pytest.mark.slow
def test_section_counts_rates_and_min_ttc(tested_run):
    run, html, _ = tested_run
    assert '<a href="#tests">Behavior tests</a>' in html
    crash, idm, aeb = _row(html, "constant-speed"), _row(html, "idm"), _row(html, "aeb")
    assert [_cell(crash, c) for c in ("n-passed", "n-failed", "n-skipped")] == ["0", "1", "0"]
    assert [_cell(idm, c) for c in ("n-passed", "n-failed", "n-skipped")] == ["0", "1", "0"]
    assert [_cell(aeb, c) for c in ("n-passed", "n-failed", "n-skipped")] == ["1", "0", "0"]
    assert _cell(crash, "collision-rate") == "1/1 (100 %)"
    assert _cell(idm, "collision-rate") == "0/1 (0 %)"
    assert _cell(crash, "min-ttc") == "0.00 s"  # it collided
    assert _cell(idm, "min-ttc").endswith(" s") and _cell(idm, "min-ttc") != "0.00 s"
    # one rate row for the behavior, one for the cause (linked to its scenario), policies a-z
    section = _tests_section(html)
    assert section.count('<tr class="rate-behavior">') == 1 and section.count('<tr class="rate-cause">') == 1
    cause = section[section.index('<tr class="rate-cause">'):]
    assert 'href="#scenario-1"' in cause and "a child runs across the road" in cause
    cells = re.findall(r'<td class="num">(\d+/\d+)', cause[:cause.index("</tr>")])
    assert cells == ["0/1", "1/1", "0/1"]  # aeb, constant-speed, idm


@pytest.mark.slow
def test_each_failure_has_its_message_and_a_gif(tested_run):
    run, html, reports = tested_run
    section = _tests_section(html)
    figures = re.findall(r'<figure class="failure">(.*?)</figure>', section, re.S)
    assert len(figures) == 2  # constant-speed and idm; aeb passed
    crash = next(f for f in figures if "constant-speed" in f)
    message = re.search(r'class="failure-message">(.*?)</span>', crash, re.S).group(1)
    assert "collision" in message and "child1" in message
    src = re.search(r'<img src="([^"]+)"', crash).group(1)
    assert src == f"tests/constant-speed/{CHILD}-v0/failure.gif"
    gif = run / unquote(src)
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.is_animated and im.n_frames > 10
    # tests.json names the picture (relative to itself) and the episode's trace is kept beside it
    case = reports["constant-speed"].cases[0]
    assert case.gif == f"{CHILD}-v0/failure.gif"
    assert (run / "tests" / "constant-speed" / f"{CHILD}-v0" / "trace.json").is_file()
    stored = json.loads((run / "tests" / "constant-speed" / "tests.json").read_text())
    assert stored["cases"][0]["gif"] == case.gif
    assert reports["aeb"].cases[0].gif is None and not (run / "tests" / "aeb" / f"{CHILD}-v0").exists()


@pytest.mark.slow
def test_regen_test_rerenders_the_report(tested_run, tmp_path):
    from typer.testing import CliRunner

    from regen.harness.cli import make_app

    run, _, _ = tested_run
    (run / "report.html").unlink()
    res = CliRunner().invoke(make_app(), [str(run), "--policy", "constant-speed"])
    assert res.exit_code == 1 and "collision rate: 1/1" in res.output
    assert f"report: {run / 'report.html'}" in res.output.replace("\n", "")
    html = (run / "report.html").read_text(encoding="utf-8")
    assert _cell(_row(html, "constant-speed"), "collision-rate") == "1/1 (100 %)"


# --- hand-written tests.json files (fast) ---------------------------------------------------------


def _case(**kw):
    base = {"scenario": "01-cause-1", "variant": 0, "status": "passed", "message": "ok",
            "collision": False, "min_ttc": 2.5, "min_distance": 1.25}
    return {**base, **kw}


def test_corrupt_tests_json_is_named_not_raised(make_run):
    run = make_run([{}])
    good = run / "tests" / "idm"
    write_json(good / "tests.json", {"policy": "idm", "oracle": "fsm", "cases": [_case()]})
    (run / "tests" / "broken").mkdir()
    (run / "tests" / "broken" / "tests.json").write_text("{not json", encoding="utf-8")
    write_json(run / "tests" / "odd" / "tests.json", {"policy": "odd", "cases": "many"})
    html = write_report(run).read_text(encoding="utf-8")
    broken = _row(html, "broken")
    assert "tests.json:" in broken and "unreadable" in broken and "JSONDecodeError" in broken
    assert "unreadable: no list of cases" in _row(html, "odd")
    assert _cell(_row(html, "idm"), "n-passed") == "1"
    assert _cell(_row(html, "idm"), "min-ttc") == "2.5 s"
    assert read_tests(run)["broken"].problem.startswith("unreadable")


def test_odd_cases_and_unsafe_picture_paths(make_run, tmp_path):
    run = make_run([{}])
    folder = run / "tests" / "mine"
    outside = tmp_path / "secret.gif"
    outside.write_bytes(b"GIF89a")
    (folder / "01-cause-1-v0").mkdir(parents=True)
    (folder / "01-cause-1-v0" / "failure.gif").write_bytes(b"GIF89a")
    cases = [
        _case(status="failed", cause="collision", collision=True, collision_with="car1", min_ttc=0.0,
              message="collision: the ego hit car1 at t=3.0 s", gif="01-cause-1-v0/failure.gif"),
        _case(status="failed", cause="off_road", message="left the road", gif=f"../../../{outside.name}"),
        _case(status="failed", cause="red_light", message="ran the light", gif=str(outside)),
        _case(status="skipped", scenario="02-gone", min_ttc=None, message="did not verify"),
        _case(status="weird", min_ttc="soon", variant="x"),
        "not a case",
    ]
    write_json(folder / "tests.json", {"policy": "pkg.mod:drive", "oracle": "safety", "cases": cases})
    view = load_run(run)
    pt = view.tests.policies[0]
    assert pt.policy == "pkg.mod:drive" and pt.problem == "1 case(s) unreadable and left out"
    assert [c.status for c in pt.cases] == ["failed", "failed", "failed", "skipped", "unknown"]
    assert [c.gif for c in pt.cases[:3]] == ["tests/mine/01-cause-1-v0/failure.gif", None, None]
    assert pt.collisions == 1 and len(pt.ran) == 3 and pt.min_ttc == 0.0
    assert pt.cases[0].cause_label == "cause 1" and pt.cases[3].cause_label == "02-gone"
    behavior, cause = view.tests.rates[0], view.tests.rates[1]
    assert behavior.kind == "behavior" and behavior.cells == [(1, 3)] and cause.cells == [(1, 3)]
    html = write_report(run).read_text(encoding="utf-8")
    assert html.count('<figure class="failure">') == 3 and not re.search(r'src="[^"]*secret', html)
    assert 'src="tests/mine/01-cause-1-v0/failure.gif"' in html


def test_no_tests_folder_no_section(make_run):
    run = make_run([{}])
    assert load_run(run).tests is None
    html = write_report(run).read_text(encoding="utf-8")
    assert 'id="tests"' not in html and "Behavior tests" not in html


def test_a_folder_of_chains_has_one_rate_row_per_behavior(make_run):
    # hand-written chains explain several behaviors: each gets its own row, its own counts
    from report_runs import make_scenario

    run = make_run([{"scenario": make_scenario(1)},
                    {"scenario": make_scenario(2, behavior_text="the ego-vehicle changes lanes")},
                    {"scenario": make_scenario(3, behavior_text="the ego-vehicle changes lanes")}])
    write_json(run / "tests" / "idm" / "tests.json", {"policy": "idm", "oracle": "fsm", "cases": [
        _case(scenario="01-cause-1", status="failed", collision=True, min_ttc=0.0),
        _case(scenario="02-cause-2"), _case(scenario="03-cause-3", status="failed", collision=True)]})
    rates = load_run(run).tests.rates
    rows = {r.label: r.cells for r in rates if r.kind == "behavior"}
    assert rows == {"the ego-vehicle stops abruptly": [(1, 1)], "the ego-vehicle changes lanes": [(1, 2)]}
    assert [r.kind for r in rates] == ["behavior", "behavior", "cause", "cause", "cause"]


def test_a_domain_that_measures_no_proximity_gets_no_time_to_collision_columns(make_run):
    door = {"text": "the robot opens the door", "domain": "manipulation", "params": {"reward": "open_door"}}
    for behavior, shown in ((door, False), (None, True)):
        run = make_run([{}], **({"behavior": behavior} if behavior else {}))
        write_json(run / "tests" / "mine" / "tests.json",
                   {"policy": "mine", "oracle": "fsm", "cases": [_case(min_ttc=None, min_distance=None)]})
        section = _tests_section(write_report(run).read_text(encoding="utf-8"))
        assert ("min time to collision" in section) is shown
        assert ('class="num min-ttc"' in section) is shown
        assert _cell(_row(section, "mine"), "n-passed") == "1"


def test_a_result_of_a_scenario_that_changed_or_went_is_marked_stale(make_run):
    from regen.harness.results import scenario_digest

    run = make_run([{}, {}])
    folder = run / "tests" / "idm"
    cases = [_case(scenario="01-cause-1"), _case(scenario="02-cause-2", status="failed", collision=True),
             _case(scenario="03-gone")]
    write_json(folder / "tests.json", {"policy": "idm", "oracle": "fsm", "cases": cases})
    for c in cases[:2]:  # what regen test keeps of each case it ran: the digest of the scenario it judged
        write_json(folder / "cases" / f"{c['scenario']}-v0.json",
                   {"digest": scenario_digest(run / "scenarios" / c["scenario"]), "case": c})
    assert [c.stale for c in load_run(run).tests.policies[0].cases] == [
        None, None, "its scenario is no longer in the run"]
    # a later run of generate replaced scenario 2: its result no longer says anything about it
    verdict = run / "scenarios" / "02-cause-2" / "verdict.json"
    verdict.write_text(verdict.read_text(encoding="utf-8").replace("verified", "unfaithful"), encoding="utf-8")
    pt = load_run(run).tests.policies[0]
    assert [c.stale for c in pt.cases] == [None, "its scenario changed since the test ran",
                                           "its scenario is no longer in the run"]
    section = _tests_section(write_report(run).read_text(encoding="utf-8"))
    assert "2 test results are of a scenario that is gone or changed" in section
    assert section.count('<span class="badge stale"') == 3  # two rows, and the failure's caption
