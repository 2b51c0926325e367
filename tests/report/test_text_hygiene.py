"""Control characters and lone surrogates in run text never reach report.html or graph.html.

A model or a hand-edited file can put NUL, BEL, ESC or half of an emoji's surrogate pair into a
narrative, a behavior or a verdict reason; the pages must stay valid UTF-8 without them, and
keep everything else (real emoji, tabs, newlines) as written.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from report_runs import make_scenario  # tests/report (see conftest)

from regen.core.behavior import Behavior
from regen.core.graph import Decision, Edge, Node, ScenarioGraph
from regen.core.verdict import Verdict
from regen.expand.pictures import write_html
from regen.report import write_report

SURROGATE = "@@LONE@@"  # replaced by a JSON '\ud83d' escape once the files are written
DIRTY = f"dirty\x00N\x07B\x1bE\x01F\x7fD\x9bC{SURROGATE}S 🐕 end"
KEPT = "dirtyNBEFDCS 🐕 end"  # what the page shows of it
# C0 controls but tab, newline and carriage return; DEL; C1 controls; lone surrogates
UNSAFE = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ud800-\udfff]")
UNSAFE_BYTES = re.compile(b"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def _insert_lone_surrogates(folder: Path) -> None:
    for f in folder.rglob("*.json"):
        text = f.read_text(encoding="utf-8")
        if SURROGATE in text:
            f.write_text(text.replace(SURROGATE, "\\ud83d"), encoding="utf-8")


def _assert_clean(page: bytes) -> str:
    assert not UNSAFE_BYTES.search(page), UNSAFE_BYTES.search(page)
    text = page.decode("utf-8")  # strict: no lone surrogate made it into the file
    assert not UNSAFE.search(text), ascii(UNSAFE.search(text).group())
    return text


def test_report_page_has_no_control_characters_or_lone_surrogates(make_run) -> None:
    sc = make_scenario(1, narrative=DIRTY, behavior_text=DIRTY)
    verdict = Verdict(feasible=False, status="fsm_incomplete", reason=DIRTY)
    run = make_run([{"scenario": sc, "verdict": verdict, "error": DIRTY,
                     "folder": "01-dirty\x07name"}],
                   behavior_text=DIRTY, message=DIRTY, status=DIRTY)
    _insert_lone_surrogates(run)
    assert "\\ud83d" in (run / "run.json").read_text()  # the files do hold the surrogate
    text = _assert_clean(write_report(run).read_bytes())
    for shown in ("Behavior", "dirtyNBEFD"):
        assert shown in text
    assert text.count(KEPT) >= 4  # behavior, narrative, verdict reason, run message
    assert "01-dirtyname" in text


def test_graph_page_has_no_control_characters_or_lone_surrogates(tmp_path: Path) -> None:
    lone = "\ud83d"
    behavior = Behavior(text=DIRTY.replace(SURROGATE, lone), domain="driving")
    graph = ScenarioGraph.start(behavior.model_copy(update={"text": "the ego stops"}))
    graph = graph.model_copy(update={"behavior": behavior,
                                     "stop_reason": DIRTY.replace(SURROGATE, lone)})
    cause = Node(id="eve-dirty", kind="event", label=DIRTY.replace(SURROGATE, lone), status="accepted",
                 depth=1, history=[Decision(action="proposed", by="model",
                                            reason=DIRTY.replace(SURROGATE, lone),
                                            call_id="c\x00" + lone)])
    graph.nodes[cause.id] = cause
    graph.edges.append(Edge(source=cause.id, target=graph.root, kind="causes"))
    page = write_html(graph, tmp_path / "graph.html").read_bytes()
    text = _assert_clean(page)
    assert KEPT in text  # the title keeps the rest of the text
    data = json.loads(re.search(r"const G = (\{.*\});\n", text).group(1))
    node = data["nodes"]["eve-dirty"]
    for value in (node["label"], node["history"][0]["reason"], *node["lines"]):
        assert not UNSAFE.search(value), ascii(value)
    assert node["label"] == KEPT


def test_graph_picture_draws_any_label(tmp_path: Path) -> None:
    """graph.png is drawn beside graph.html: a lone surrogate or a '$' pair (matplotlib math)
    in a label must not cost the pictures."""
    from regen.expand.pictures import draw_png

    label = DIRTY.replace(SURROGATE, "\ud83d") + " costs $x^$ and $\\frac{$"
    graph = ScenarioGraph.start(Behavior(text="the ego stops", domain="driving"))
    graph = graph.model_copy(update={"behavior": Behavior(text=label, domain="driving")})
    cause = Node(id="eve-dirty", kind="event", label=label, status="accepted", depth=1)
    graph.nodes[cause.id] = cause
    graph.edges.append(Edge(source=cause.id, target=graph.root, kind="causes"))
    out = draw_png(graph, tmp_path / "graph.png")
    assert out.stat().st_size > 0
