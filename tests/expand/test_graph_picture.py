"""graph.png: every node's box where the layout puts it, in its kind's colour, and arrows from
each cause's box to its effect's, ending apart on the effect's left edge."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fake_expansion_model import ScriptedModel
from PIL import Image

from regen.core.behavior import Behavior
from regen.errors import ConfigError
from regen.expand import Limits
from regen.expand.pictures import COLORS, compact, draw_png, picture_layout
from regen.expand.run import run_expand
from regen.llm import LLM
from regen.llm.testing import FunctionProvider

STOP = "the ego-vehicle stops abruptly"


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    model = ScriptedModel(
        causes={STOP: ["a jaywalker walked in front", "an ambulance approaches from behind", "a tree fell in front"],
                "an ambulance approaches from behind": ["a traffic accident happened ahead"]},
        plausible={}, values={},
        entities={"a jaywalker walked in front": ["adult"], "an ambulance approaches from behind": ["ambulance"],
                  "a traffic accident happened ahead": ["sedan", "police_car"], "a tree fell in front": ["tree"]},
        choose={"siren": ["on"], "behavior": ["drive_forward"], "start_location": ["behind_same_lane"]})
    out = tmp_path_factory.mktemp("graph")
    return run_expand(Behavior(text=STOP, domain="driving"), LLM(FunctionProvider(model)), out,
                      limits=Limits(max_depth=2, max_causes=4, max_entities=3)).graph


def _rgb(hex_color: str) -> tuple[int, int, int]:
    return tuple(int(hex_color[k: k + 2], 16) for k in (1, 3, 5))


def test_each_box_is_drawn_where_the_layout_puts_it_in_its_kinds_colour(graph, tmp_path: Path) -> None:
    pic = picture_layout(graph)
    img = np.asarray(Image.open(draw_png(graph, tmp_path / "graph.png")).convert("RGB"))
    assert img.shape == (pic.height, pic.width, 3)
    kinds = {b.kind for b in pic.boxes.values()}
    assert kinds == {"event", "entity", "property"}
    for box in pic.boxes.values():
        # inside the box at its left end, between the outline and the centred text
        inside = tuple(int(v) for v in img[round(box.middle), int(box.left) + 4])
        if box.node == graph.root:
            assert inside == _rgb(COLORS["behavior"])
        elif box.muted:  # rejected or unsimulatable: a light grey
            assert min(inside) >= 200 and max(inside) - min(inside) <= 2, (box.lines, inside)
        else:
            assert inside == _rgb(COLORS[box.kind]), (box.lines, inside)
        outside = img[int(box.top) - 3, int((box.left + box.right) / 2)]  # just above: white or an arrow
        assert tuple(int(v) for v in outside) != tuple(inside)
    tree = next(b for b in pic.boxes.values() if b.lines[0] == "a tree fell in front")
    assert tree.muted and tree.lines[-1] == "(not simulatable)"


def test_arrows_run_from_a_cause_to_its_effect_and_touch_both_boxes(graph, tmp_path: Path) -> None:
    pic = picture_layout(graph)
    img = np.asarray(Image.open(draw_png(graph, tmp_path / "graph.png")).convert("L")).astype(int)
    drawn = compact(graph)  # what the picture shows: an entity's chosen values in one box
    assert {(a.accepted, a.start[1]) for a in pic.arrows} == {
        (e.status == "accepted", pic.boxes[e.source].middle) for e in drawn.edges}
    assert len([a for a in pic.arrows if a.accepted]) == len([e for e in drawn.edges if e.status == "accepted"]) >= 8
    right_edges = {b.right for b in pic.boxes.values()}
    left_edges = {b.left for b in pic.boxes.values()}
    for a in pic.arrows:
        (x0, y0), (x1, y1) = a.start, a.end
        assert x0 < x1 and x0 in right_edges and x1 in left_edges  # left to right, box to box
        if not a.accepted:
            continue
        for f in (0.1, 0.5, 0.9):  # dark along the line, from the first box to the arrow head
            x, y = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
            assert img[round(y) - 1: round(y) + 2, round(x) - 1: round(x) + 2].min() < 140, (a, f)


def test_arrows_into_one_box_end_apart_in_the_order_of_their_sources(graph) -> None:
    pic = picture_layout(graph)
    root = pic.boxes[graph.root]
    into = sorted((a for a in pic.arrows if a.end[0] == root.left), key=lambda a: a.start[1])
    assert len(into) == 3
    ends = [a.end[1] for a in into]
    assert ends == sorted(ends) and len(set(ends)) == 3
    assert root.top < ends[0] and ends[-1] < root.bottom


def test_a_picture_is_a_png(graph, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"\.png"):
        draw_png(graph, tmp_path / "graph.svg")
    assert not (tmp_path / "graph.svg").exists()


def test_a_graph_too_large_to_draw_twice_the_size_is_drawn_at_its_size(graph, tmp_path: Path, monkeypatch) -> None:
    """Boxes and arrows are drawn at twice the size and halved, unless that drawing would pass
    MAX_SUPERSAMPLED_PX (a graph of hundreds of nodes): then at the picture's size, with every
    box and arrow where the layout puts them all the same."""
    from regen.expand import pictures

    pic = picture_layout(graph)
    monkeypatch.setattr(pictures, "MAX_SUPERSAMPLED_PX", pic.width * pic.height * 2)  # < 4x the area
    made = []
    new = Image.new
    monkeypatch.setattr(pictures.Image, "new", lambda mode, size, *a: (made.append(size), new(mode, size, *a))[1])
    img = np.asarray(Image.open(draw_png(graph, tmp_path / "graph.png")).convert("RGB"))
    assert (pic.width, pic.height) in made and (2 * pic.width, 2 * pic.height) not in made
    assert img.shape == (pic.height, pic.width, 3)
    for box in pic.boxes.values():
        if not box.muted and box.node != graph.root:
            assert tuple(int(v) for v in img[round(box.middle), int(box.left) + 4]) == _rgb(COLORS[box.kind])
    for a in pic.arrows:
        if a.accepted:
            (x0, y0), (x1, y1) = a.start, a.end
            x, y = (x0 + x1) / 2, (y0 + y1) / 2
            assert img[round(y) - 1: round(y) + 2, round(x) - 1: round(x) + 2].min() < 140


def test_a_long_behavior_is_cut_to_the_pictures_width(graph) -> None:
    """The title is the behavior: a long one ends in an ellipsis at the picture's width instead
    of widening the picture past its columns."""
    from regen.core.behavior import Behavior
    from regen.media import text_font, text_length

    long = graph.model_copy(update={"behavior": Behavior(text=STOP + ", " + "very " * 80 + "slowly",
                                                         domain="driving")})
    short, cut = picture_layout(graph), picture_layout(long)
    assert cut.width == short.width
    assert cut.title.endswith("\u2026") and cut.title.startswith("Scenario graph: " + STOP)
    assert text_length(cut.title, text_font(16)) <= cut.width - 2 * 24
