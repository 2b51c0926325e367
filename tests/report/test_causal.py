"""The causal check (does the cause cause the behavior?) beside the verdict status in the report:
a badge and the reason per scenario, the reference runs with and without the cause, the other
entities, a column in the overview table, and a column in the behavior tests. A verdict.json
written before the check existed shows no causal part and breaks nothing."""

from __future__ import annotations

import re
from html import unescape
from pathlib import Path

from report_runs import HOSTILE, verified  # tests/report (see conftest)

from regen.core.io import write_json
from regen.core.verdict import Causal, EntityCheck, ReferenceRun, Verdict
from regen.report import load_run, write_report
from regen.report.load import causal_label, causal_text

BY = "reference driver (IDM, MOBIL)"


def caused() -> Causal:
    return Causal(status="caused", by=BY, behavior="stops", cause=["car1"], cause_from="named by the cause's words",
                  reason="the reference driver stopped at t = 6.1 s; with car1 removed it does not",
                  with_cause=ReferenceRun(shown=True, happened=True, reacted_to="car1", onset=6.1, cause_at=2.5,
                                          summary="stopped at t = 6.1 s, 9.8 m before car1"),
                  without_cause=ReferenceRun(removed=["car1"], shown=False, happened=False,
                                             summary="drove on at 10 m/s"),
                  others=[EntityCheck(entity="cone1", alone_shows=False, without_it_shows=True)])


def confounded() -> Causal:
    return Causal(status="confounded", by=BY, behavior="stops", cause=["car1"],
                  reason="traffic_light1 alone makes the reference driver stop, without car1: stopped at t = 4.0 s",
                  with_cause=ReferenceRun(shown=True, summary="stopped at t = 4.0 s at the stop line"),
                  without_cause=ReferenceRun(removed=["car1"], shown=True, happened=True,
                                             reacted_to="traffic_light1", summary="stopped at t = 4.0 s (red light)"),
                  others=[EntityCheck(entity="traffic_light1", alone_shows=True, without_it_shows=False),
                          EntityCheck(entity="cone1")],
                  confounders=["traffic_light1"])


def with_causal(causal: Causal | None) -> Verdict:
    v = verified()
    v.causal = causal
    return v


def _section(html: str, anchor: str) -> str:
    start = html.index(f'id="{anchor}"')
    end = html.find('<section class="scenario"', start + 1)
    return html[start:end if end > 0 else len(html)]


def _row(html: str, n: int) -> str:
    start = html.index(f'id="row-{n}"')
    return html[start:html.index("</tr>", start)]


def _text(fragment: str) -> str:
    return re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", fragment)))


def _cells(html: str, marker: str, end: str = "</tr>") -> list[str]:
    """The words of the element whose start tag holds ``marker``, up to ``end``."""
    start = html.rfind("<", 0, html.index(marker))
    return _text(html[start:html.index(end, start)]).split()


def test_the_words_of_a_causal_part() -> None:
    assert causal_text(None) is None and causal_label(None) == "not checked"
    assert causal_text(caused()) == "caused" and causal_label(caused()) == "caused"
    assert causal_text(confounded()) == "confounded: traffic_light1"
    assert causal_label(confounded()) == "confounded by traffic_light1"
    assert causal_label(Causal(status="not_sufficient", reason="ignored")) == "not sufficient"


def test_each_scenario_shows_its_causal_part_beside_the_status(make_run) -> None:
    run = make_run([{"verdict": with_causal(caused())}, {"verdict": with_causal(confounded())},
                    {"verdict": verified()}])  # the last one: a verdict.json from before the check
    html = write_report(run).read_text(encoding="utf-8")

    first = _section(html, "scenario-1")
    heading = first[:first.index("</h2>")]
    assert "verified" in heading and "Cause: caused" in heading  # beside the status, not instead
    assert "badge cause cause-caused" in heading
    assert "with car1 removed it does not" in first
    assert _cells(first, 'class="with-cause"') == [*"with the cause yes car1".split(),
                                                    *"stopped at t = 6.1 s, 9.8 m before car1".split()]
    assert _cells(first, 'class="without-cause"') == [*"without the cause (removed: car1) no —".split(),
                                                       *"drove on at 10 m/s".split()]
    assert _cells(first, 'class="other-entity"') == ["cone1", "no", "yes"]
    assert BY in first

    second = _section(html, "scenario-2")
    heading = second[:second.index("</h2>")]
    assert "verified" in heading and "Cause: confounded by traffic_light1" in heading
    assert "traffic_light1 alone makes the reference driver stop" in second
    assert "stopped at t = 4.0 s (red light)" in second
    assert _cells(second, 'class="other-entity confounder"') == ["traffic_light1", "(confounder)", "yes", "no"]
    assert _cells(second, 'class="other-entity"') == ["cone1", "—", "—"]

    third = _section(html, "scenario-3")
    assert "Cause:" not in third and "causal-runs" not in third and 'class="causal"' not in third
    assert "verified" in third[:third.index("</h2>")]


def test_the_overview_table_and_summary_count_the_caused(make_run) -> None:
    run = make_run([{"verdict": with_causal(caused())}, {"verdict": with_causal(confounded())},
                    {"verdict": verified()}, {"verdict": None}])
    assert load_run(run).summary.causal == {"caused": 1, "confounded": 1}
    html = write_report(run).read_text(encoding="utf-8")
    table = html[html.index('<table class="scenarios">'):]
    assert "<th>caused</th>" in table[:table.index("</thead>")]
    assert ">caused</span>" in _row(html, 1)
    assert "confounded by traffic_light1" in _row(html, 2)
    assert _cells(_row(html, 3), 'class="caused"', "</td>") == ["—"]
    assert _cells(_row(html, 1), 'class="caused"', "</td>") == ["caused"]
    counts = " ".join(_cells(html, 'class="causal-counts"', "</p>"))
    assert "caused 1" in counts and "confounded 1" in counts


def test_a_run_without_any_causal_check_shows_none(make_run) -> None:
    html = write_report(make_run([{}, {"verdict": None}])).read_text(encoding="utf-8")
    assert "causal-counts" not in html and "Cause:" not in html and "causal-runs" not in html


def test_hostile_causal_text_is_escaped(make_run) -> None:
    bad = confounded()
    bad.reason, bad.confounders = HOSTILE, [HOSTILE]
    bad.with_cause.summary = HOSTILE
    html = write_report(make_run([{"verdict": with_causal(bad)}])).read_text(encoding="utf-8")
    assert "<script" not in html.lower() and "<b>bold" not in html
    assert "&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;" in _section(html, "scenario-1")


def _tests_json(run: Path, cases: list[dict]) -> None:
    write_json(run / "tests" / "idm" / "tests.json", {"run": str(run), "policy": "idm", "oracle": "fsm",
                                                      "cases": cases})


def test_behavior_tests_show_the_scenarios_causal_check(make_run) -> None:
    run = make_run([{"verdict": with_causal(confounded())}, {"verdict": with_causal(caused())}, {}])
    _tests_json(run, [
        {"scenario": "01-cause-1", "variant": 0, "status": "failed", "cause": "state_not_reached",
         "message": "expected state 2 of 2 not reached", "causal": "confounded: traffic_light1"},
        {"scenario": "02-cause-2", "variant": 0, "status": "passed", "message": "all reached",
         "causal": "caused"},
        {"scenario": "03-cause-3", "variant": 0, "status": "passed", "message": "all reached"},  # an older file
    ])
    view = load_run(run)
    rows = view.tests.policies[0].cases
    assert [c.causal for c in rows] == ["confounded: traffic_light1", "caused", None]
    assert rows[0].causal_label == "confounded by traffic_light1" and rows[0].causal_status == "confounded"
    html = write_report(run).read_text(encoding="utf-8")
    start = html.index('<h2 id="tests">')
    section = html[start:html.index('<h2 id="', start + 1)]  # up to the next section
    failure = section[section.index('<figure class="failure">'):section.index("</figure>")]
    assert "confounded by traffic_light1" in failure
    assert "another entity alone explains the behavior" in failure
    cases = section[section.index('<table class="cases">'):]
    assert "<th>causal</th>" in cases[:cases.index("</thead>")]
    body = cases[cases.index("<tbody>"):cases.index("</tbody>")]
    cells = [_text(c).strip() for c in re.findall(r'<td class="causal">(.*?)</td>', body, re.S)]
    assert cells == ["confounded by traffic_light1", "caused", "—"]


def test_the_narratives_claims_the_simulation_does_not_show_are_listed(make_run) -> None:
    v = with_causal(caused())
    v.claims = ["the model's claim: 'It stops, causing a collision.' ('collision'); the simulation shows no collision"]
    run = make_run([{"verdict": v}, {"verdict": with_causal(caused())}])
    html = write_report(run).read_text(encoding="utf-8")
    first, second = _section(html, "scenario-1"), _section(html, "scenario-2")
    assert "claims what did not happen" in first and "the simulation shows no collision" in _text(first)
    assert "claims what did not happen" not in second
