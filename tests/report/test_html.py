"""The report page: content, links, escaping and robustness against broken run folders."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from report_runs import HOSTILE, incomplete, make_scenario, verified  # tests/report (see conftest)

from regen.errors import ConfigError, RegenError
from regen.report import load_run, write_report


class Page(HTMLParser):
    """Tags with their attributes plus the text inside elements with an id/class of interest."""

    def __init__(self, html: str):
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict[str, str]]] = []
        self.text: list[str] = []
        self.feed(html)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, {k: v or "" for k, v in attrs}))

    def handle_data(self, data: str) -> None:
        self.text.append(data)

    def find(self, tag: str, cls: str | None = None) -> list[dict[str, str]]:
        return [a for t, a in self.tags
                if t == tag and (cls is None or cls in a.get("class", "").split())]

    def by_id(self, ident: str) -> dict[str, str] | None:
        return next((a for _, a in self.tags if a.get("id") == ident), None)

    @property
    def all_text(self) -> str:
        return "".join(self.text)


def _page(run: Path) -> tuple[str, Page]:
    out = write_report(run)
    assert out == run / "report.html"
    html = out.read_text(encoding="utf-8")
    return html, Page(html)


def _section(html: str, anchor: str) -> str:
    start = html.index(f'id="{anchor}"')
    end = html.find('<section class="scenario"', start)
    return html[start:end if end > 0 else len(html)]


def _local_refs(page: Page) -> list[str]:
    refs = [a["href"] for a in page.find("a") if "href" in a] + [a["src"] for a in page.find("img")]
    return [r for r in refs if not r.startswith("#")]


def test_one_table_row_per_scenario_each_linking_to_its_section(make_run) -> None:
    run = make_run([{}, {"verdict": incomplete()}, {}])
    html, page = _page(run)
    rows = page.find("tr", "scenario-row")
    assert len(rows) == 3
    for n in (1, 2, 3):
        assert page.by_id(f"scenario-{n}") is not None
        assert any(a.get("href") == f"#scenario-{n}" for a in page.find("a"))
    # the chain reads root cause -> ... -> behavior, in that order
    first = html.index("cause 1")
    assert first < html.index("a car cuts in", first) < html.index("the ego-vehicle stops abruptly", first)
    assert "ambulance" in _section(html, "row-1")


def test_summary_counts_and_success_rate(make_run) -> None:
    run = make_run([{}, {}, {"verdict": incomplete()}, {"verdict": None}])
    view = load_run(run)
    s = view.summary
    assert (s.total, s.finished, s.feasible) == (4, 3, 2)
    assert s.success_rate == pytest.approx(2 / 3)
    assert s.statuses == {"fsm_incomplete": 1, "unfinished": 1, "verified": 2}
    html, page = _page(run)
    rate = html[html.index('id="success-rate"'):]
    assert rate.split(">", 1)[1].startswith("67 %")
    assert html[html.index('id="n-total"'):].split(">", 1)[1].startswith("4<")


def test_success_rate_without_verdicts_is_not_a_number(make_run) -> None:
    run = make_run([{"verdict": None}])
    assert load_run(run).summary.success_rate is None
    html, _ = _page(run)
    assert html[html.index('id="success-rate"'):].split(">", 1)[1].startswith("—")


def test_hostile_text_is_escaped_everywhere(make_run) -> None:
    sc = make_scenario(1, narrative=HOSTILE, agent_name=HOSTILE, behavior_text=HOSTILE)
    run = make_run([{"scenario": sc, "verdict": verified(HOSTILE), "folder": "01-<b>&\"x\"",
                     "error": HOSTILE}], behavior_text=HOSTILE)
    html, page = _page(run)
    assert "<script" not in html.lower()
    assert "<b>" not in html
    assert "&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "&amp; &lt;b&gt;bold&lt;/b&gt;" in html
    # the parsed text still shows what was written, once decoded
    assert HOSTILE in page.all_text
    # the odd folder name is percent-encoded in links and still reaches the files
    gif = next(a["src"] for a in page.find("img") if a["src"].endswith("bird_eye.gif"))
    assert "<" not in gif and '"' not in gif
    assert (run / unquote(gif)).is_file()


def test_links_exist_only_for_files_on_disk(make_run) -> None:
    run = make_run([{"scenic": True, "xosc": True, "trace": True},
                    {"gif": False, "keyframes": False}],
                   graph_html=False)
    html, page = _page(run)
    refs = _local_refs(page)
    for ref in refs:  # every relative link and picture points at a real file
        assert urlsplit(ref).scheme == "", ref
        assert (run / unquote(ref)).is_file(), ref
    one, two = _section(html, "scenario-1"), _section(html, "scenario-2")
    for name in ("scenario.scenic", "scenario.xosc", "trace.json", "bird_eye.gif", "keyframes.png"):
        assert f"01-cause-1/{name}" in one
        assert name not in two.replace("01-cause-1", "")
    assert "graph.html" not in refs and "graph.png" in refs
    assert "Pictures:" in two and "missing" in two


def test_missing_and_broken_files_are_shown_not_raised(make_run) -> None:
    run = make_run([{"scenario": None, "verdict": None, "gif": False},
                    {"verdict": None, "raw": {"verdict.json": "{not json"}},
                    {"verdict": None, "raw": {"verdict.json": json.dumps({"feasible": "maybe"})}}],
                   graph_png=False)
    (run / "graph.json").write_text("[]")
    html, page = _page(run)
    one, two, three = (_section(html, f"scenario-{n}") for n in (1, 2, 3))
    assert "scenario.json: <span class=\"missing\">missing</span>" in one
    assert "verdict.json: <span class=\"missing\">missing</span>" in one
    assert "unreadable" in two and "JSONDecodeError" in two
    assert "unreadable" in three
    assert "graph.png: <span class=\"missing\">missing</span>" in html
    assert "graph.json: <span class=\"missing\">unreadable" in html
    statuses = load_run(run).summary.statuses
    assert statuses == {"unfinished": 1, "unreadable": 2}


def test_run_without_run_json_takes_the_behavior_from_the_graph(make_run) -> None:
    run = make_run([{}])
    (run / "run.json").unlink()
    html, page = _page(run)
    assert "run.json: <span class=\"missing\">missing</span>" in html
    assert "\u201cthe ego-vehicle stops abruptly\u201d" in page.all_text
    assert len(page.find("tr", "scenario-row")) == 1  # folders on disk still count


def test_the_behavior_parameters_are_shown_whatever_the_domain_calls_them(make_run) -> None:
    run = make_run([{}])
    html, _ = _page(run)
    assert '<span class="tag">ego template: stop_abruptly</span>' in html
    # a run.json of before Behavior.params (the parameters at the top level, nulls too)
    data = json.loads((run / "run.json").read_text())
    data["behavior"] = {"text": "the robot opens the door", "domain": "manipulation", "ego_template": None,
                        "route": [{"x": 0.0, "y": 1.0, "speed": None}], "reward": "open_door"}
    (run / "run.json").write_text(json.dumps(data))
    html, _ = _page(run)
    assert '<span class="tag">reward: open_door</span>' in html and "route: 1 entry" in html
    assert "ego template" not in html


def test_empty_folder_still_gets_a_report(tmp_path: Path) -> None:
    html, page = _page(tmp_path)
    assert "no scenarios in this run yet" in html
    assert page.find("tr", "scenario-row") == []


def test_not_a_folder_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError):
        write_report(tmp_path / "nope")
    assert issubclass(ConfigError, RegenError)


def test_unsafe_folder_names_in_run_json_are_not_followed(make_run, tmp_path: Path) -> None:
    outside = tmp_path / "secret"
    outside.mkdir()
    (outside / "verdict.json").write_text(verified().model_dump_json())
    run = make_run([{}], scenarios=["../../secret", "01-cause-1", "02-gone"])
    view = load_run(run)
    assert [s.folder for s in view.scenarios] == ["01-cause-1"]
    assert view.stray == ["../../secret", "02-gone"]
    html, _ = _page(run)
    assert "not on disk" in html


def test_unmet_stage_is_highlighted_with_per_condition_times(make_run) -> None:
    run = make_run([{"verdict": incomplete()}])
    html, page = _page(run)
    section = _section(html, "scenario-1")
    assert len(page.find("tr", "stage-reached")) == 1
    assert len(page.find("tr", "stage-unmet")) == 1
    unmet = section[section.index('class="stage-unmet"'):]
    assert "held alone at 3.75 s" in unmet and "never held alone" in unmet
    assert "not reached" in unmet
    reached = section[section.index('class="stage-reached"'):section.index('class="stage-unmet"')]
    assert "2.5 s" in reached
    # the state definitions come from the scenario's FSM
    assert "in_front_of(car1, ego, distance=10.0)" in section


def test_verified_scenario_details(make_run) -> None:
    run = make_run([{"error": "Traceback: boom <here>"}])
    html, _ = _page(run)
    section = _section(html, "scenario-1")
    assert "stage-unmet" not in section
    assert "6.4 s" in section
    assert "12.346" in section  # solved parameter, rounded to 3 decimals
    assert "widened the gap range to 5-15 m" in section
    assert "optimal" in section
    assert "Traceback: boom &lt;here&gt;" in section
    assert "siren: on" in section


def test_settings_timings_and_usage_are_listed(make_run) -> None:
    html, page = _page(make_run([{}]))
    assert "4321" in html and "765" in html  # tokens in/out, total
    usage = html[html.index('class="usage"'):]
    usage = usage[:usage.index("</table>")]
    assert usage.count("<tr") == 4  # header, expand, ground, total
    assert "40.2 s" in html or "40.3 s" in html  # simulate stage time
    assert "max_scenarios" in html


def test_model_time_of_cache_hits_is_explained_only_when_there_are_some(make_run) -> None:
    """A run replayed from its cache shows the first answers' model time: the page says so."""
    html, _ = _page(make_run([{}]))  # 2 cache hits
    assert "each of the 2 cache hit(s) at the time the model took when it first gave that answer" in html
    usage = {"total": {"calls": 3, "model_calls": 3, "cache_hits": 0, "latency": 9.0},
             "by_purpose": {"expand": {"calls": 3, "model_calls": 3, "cache_hits": 0, "latency": 9.0}}}
    html, _ = _page(make_run([{}], usage=usage))
    assert "cache hit(s) at the time" not in html and "9.0 s" in html


def test_page_is_self_contained(make_run) -> None:
    html, page = _page(make_run([{}, {"verdict": incomplete()}]))
    assert "<script" not in html
    assert page.find("link", None) == [{"rel": "icon", "href": "data:,"}]
    for ref in _local_refs(page):
        assert not ref.startswith(("http:", "https:", "//")), ref


def test_odd_run_json_values_do_not_break_the_page(make_run) -> None:
    run = make_run([{}], settings=["not", "a", "dict"], timings={"expand": "soon", "ground": True},
                   usage={"total": 5, "by_purpose": {"x": 3}}, scenarios="01-cause-1",
                   started=12, message="<i>stopped</i> & resumed")
    html, page = _page(run)
    assert "no settings recorded" in html
    assert "no model usage recorded" in html
    timings = html[html.index('class="kv timings"'):]
    assert timings.index("expand") < timings.index("—")  # a value that is no number shows as a dash
    assert "&lt;i&gt;stopped&lt;/i&gt; &amp; resumed" in html
    assert len(page.find("tr", "scenario-row")) == 1
