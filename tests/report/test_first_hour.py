"""The report as a new user meets it: the scenarios first (a gallery), then the graph, then the
settings; every solved number with its meaning and unit; model calls by purpose, not by hash;
the graph's counts matching its table."""

from __future__ import annotations

import re
import sqlite3
from html import unescape
from pathlib import Path

from report_runs import incomplete, make_scenario, verified  # tests/report (see conftest)

from regen.core.graph import Node, ScenarioGraph, node_id
from regen.core.io import write_json
from regen.report import write_report
from regen.report.html import call_ids

ROLES_CALL = "a" * 60 + "1234"
FSM_CALL = "0123abcd" + "e" * 56


def _text(fragment: str) -> str:
    text = re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", fragment))).strip()
    return text.replace(" ,", ",")


def _driving_scenario(n: int):
    sc = make_scenario(n)
    sc.parameters = {"car1": {"s": -77.8, "v": 12.0, "t": 3.5}}
    sc.world = {"map": "straight", "duration": 16.0, "dt": 0.1, "seed": 0,
                "model_calls": f"{ROLES_CALL},{FSM_CALL}"}
    return sc


def test_the_scenarios_come_first_then_the_graph_then_settings_and_usage(make_run) -> None:
    html = write_report(make_run([{}, {"verdict": incomplete()}])).read_text(encoding="utf-8")
    order = ['<h2 id="summary">', '<h2 id="scenarios">', '<div class="gallery">', '<table class="scenarios">',
             '<h2 id="graph">', '<h2 id="run">', '<table class="kv settings">', '<table class="usage">',
             '<h2 id="details">', '<section class="scenario" id="scenario-1">']
    at = [html.index(marker) for marker in order]
    assert at == sorted(at), [m for m, _ in sorted(zip(order, at, strict=True), key=lambda x: x[1])]
    # the navigation follows the page
    nav = html[html.index("<nav>"):html.index("</nav>")]
    links = re.findall(r'href="#([^"]+)"', nav)
    assert links == ["summary", "scenarios", "graph", "run", "details"]


def test_each_scenario_has_a_gallery_card_with_picture_title_verdict_cause_and_why(make_run) -> None:
    run = make_run([{}, {"verdict": incomplete(), "keyframes": False}, {"verdict": None, "gif": False,
                                                                         "keyframes": False}])
    html = write_report(run).read_text(encoding="utf-8")
    gallery = html[html.index('<div class="gallery">'):html.index('<table class="scenarios">')]
    cards = re.findall(r'<a class="card-link" href="#(scenario-\d)" id="card-\d">(.*?)</a>', gallery, re.S)
    assert [a for a, _ in cards] == ["scenario-1", "scenario-2", "scenario-3"]
    one, two, three = (body for _, body in cards)
    assert 'src="scenarios/01-cause-1/keyframes.png"' in one  # the key frames' last tile
    assert 'src="scenarios/02-cause-2/bird_eye.gif"' in two  # no key frames: the animation
    assert "no picture" in three
    assert "cause 1" in _text(one) and "verified" in _text(one)  # the root cause is the title
    assert "all 2 stages reached in order" in _text(one)  # one line of why
    assert "fsm incomplete" in _text(two) and "stage 2" in _text(two)
    assert "causal: not checked" in _text(one)  # these verdicts have no causal part
    assert "verdict.json: missing" in _text(three)
    # back from a scenario's details to its card
    assert 'href="#card-2"' in html[html.index('id="scenario-2"'):]


def test_solved_parameters_and_world_settings_show_meaning_and_unit(make_run) -> None:
    html = write_report(make_run([{"scenario": _driving_scenario(1)}])).read_text(encoding="utf-8")
    params = html[html.index('<table class="parameters">'):]
    params = params[:params.index("</table>")]
    rows = [_text(r) for r in re.findall(r"<tr>(.*?)</tr>", params, re.S)[1:]]
    assert rows == ["car1 s start position along the ego's road -77.8 m", "car1 v speed 12.0 m/s",
                    "car1 t time it acts, from the start 3.5 s"]
    world = html[html.index('<table class="kv world">'):]
    world = _text(world[:world.index("</table>")])
    assert "duration simulated time 16.0 s" in world and "dt simulation step 0.1 s" in world
    assert "seed random seed 0" in world  # a number without a unit stays bare
    assert "0 s" not in world.replace("16.0 s", "").replace("0.1 s", "")


def test_a_toy_domain_without_quantities_shows_its_names_as_they_are(make_run) -> None:
    sc = make_scenario(1)
    html = write_report(make_run([{"scenario": sc}])).read_text(encoding="utf-8")
    params = html[html.index('<table class="parameters">'):]
    assert "12.346</td>" in params[:params.index("</table>")]  # 'speed' of make_scenario: no unit known


def test_model_calls_read_as_purpose_and_short_id_with_the_hash_in_a_title(make_run) -> None:
    run = make_run([{"scenario": _driving_scenario(1)}])
    db = sqlite3.connect(run / "llm-cache.sqlite")
    db.execute("CREATE TABLE calls (key TEXT PRIMARY KEY, provider TEXT, purpose TEXT, response TEXT, "
               "input_tokens INTEGER, output_tokens INTEGER, latency REAL, created REAL, failed INTEGER)")
    db.execute("INSERT INTO calls VALUES (?, 'local', 'ground_roles', '{}', 1, 1, 0.1, 0, 0)", (ROLES_CALL,))
    db.commit()
    db.close()
    html = write_report(run).read_text(encoding="utf-8")
    world = html[html.index('<table class="kv world">'):]
    world = world[:world.index("</table>")]
    row = next(r for r in re.findall(r"<tr>(.*?)</tr>", world, re.S) if "model_calls" in r)
    assert _text(row) == "model_calls the model's answers used ground_roles #aaaaaaaa, model call #0123abcd"
    assert f'title="model call {ROLES_CALL}"' in row and f'title="model call {FSM_CALL}"' in row
    assert ROLES_CALL not in _text(row)  # the hash is not printed, only kept in the title
    assert call_ids(f"{ROLES_CALL},{FSM_CALL}") == [ROLES_CALL, FSM_CALL]
    assert call_ids("ground_roles") == [] and call_ids(ROLES_CALL[:-1]) == []


def test_the_graph_counts_the_causes_its_table_lists(make_run) -> None:
    run = make_run([{}])
    graph = ScenarioGraph.model_validate_json((run / "graph.json").read_text())
    for label, status in (("a car cuts in", "accepted"), ("a dog runs", "accepted"), ("it rains", "rejected")):
        graph.add_node(Node(id=node_id("event", label), kind="event", label=label, status=status, depth=1))
    write_json(run / "graph.json", graph)
    html = write_report(run).read_text(encoding="utf-8")
    section = html[html.index('<h2 id="graph">'):html.index('<h2 id="run">')]
    table = section[section.index('<table class="causes">'):section.index("</table>")]
    assert table.count("<tr>") == 1 + 3  # header and the three causes, the behavior not among them
    start = section.index('<p class="muted graph-counts">')
    counts = _text(section[start:section.index("</p>", start)])
    assert counts.startswith("2 of 3 cause events accepted")
    assert "4 nodes in all" in counts


def test_verdict_reason_in_a_card_is_one_line_with_the_whole_text_in_its_title(make_run, tmp_path: Path) -> None:
    long = verified()
    long.reason = "all 2 stages reached in order; " + "a very long explanation " * 20
    html = write_report(make_run([{"verdict": long}])).read_text(encoding="utf-8")
    why = re.search(r'<span class="card-why" title="([^"]*)">', html)
    assert why is not None and unescape(why.group(1)) == long.reason
