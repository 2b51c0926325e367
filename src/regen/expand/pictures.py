"""Pictures of a scenario graph: a static PNG (Pillow) and an interactive HTML page that works
offline (inline SVG and script, no CDN). Node kinds have distinct colors and shapes; rejected and
unsimulatable nodes stay visible but muted, so the audit trail can be seen.

``graph.png`` (:func:`draw_png`): columns left to right, properties, entities, causes by depth
(deepest first), the behavior (:func:`layout`); one box per node in its kind's colour and an
arrow from each cause to its effect that leaves the right edge of one box and ends on the left
edge of the other. Boxes and arrows are drawn at twice the size and halved (smooth edges), the
text afterwards at full size (sharp glyphs); everything sits where :func:`picture_layout` says.
It replaced a matplotlib figure that took about 0.14 s a run, most of it laying text out twice.
"""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass
from pathlib import Path

from PIL import Image, ImageColor, ImageDraw

from regen import media
from regen.core.graph import ScenarioGraph
from regen.core.io import atomic_write_text
from regen.core.text import clean_data
from regen.errors import ConfigError

COLORS = {"event": "#4C78A8", "entity": "#F58518", "property": "#54A24B", "behavior": "#B279A2"}
MUTED = "#BBBBBB"

_clean = clean_data  # every string of the page's data without unsafe characters (regen.core.text)


def layout(graph: ScenarioGraph) -> dict[str, tuple[float, float]]:
    """Columns left to right: properties, entities, events by depth (deepest first), behavior.
    Rows ordered so that nodes sit near what they connect to (one barycentre sweep)."""
    max_depth = max((n.depth for n in graph.nodes.values() if n.kind == "event"), default=0)
    col: dict[str, int] = {}
    for n in graph.nodes.values():
        if n.kind == "property":
            col[n.id] = 0
        elif n.kind == "entity":
            col[n.id] = 1
        else:
            col[n.id] = 2 + (max_depth - n.depth)
    targets: dict[str, list[str]] = {}
    for e in graph.edges:
        targets.setdefault(e.source, []).append(e.target)
    rows: dict[str, float] = {}
    for c in sorted(set(col.values()), reverse=True):
        members = [nid for nid, cc in col.items() if cc == c]

        def key(nid: str) -> tuple[float, int, str]:
            ts = [rows[t] for t in targets.get(nid, []) if t in rows]
            status_rank = 0 if graph.nodes[nid].status == "accepted" else 1
            return (sum(ts) / len(ts) if ts else 0.0, status_rank, graph.nodes[nid].label)

        members.sort(key=key)
        for i, nid in enumerate(members):
            rows[nid] = float(i)
    # centre each column vertically
    height = max((sum(1 for v in col.values() if v == c) for c in set(col.values())), default=1)
    pos = {}
    for nid, c in col.items():
        count = sum(1 for v in col.values() if v == c)
        pos[nid] = (float(c), rows[nid] + (height - count) / 2.0)
    return pos


def _wrap(text: str, width: int = 22) -> str:
    words, lines, cur = text.split(), [], ""
    for w in words:
        if len(cur) + len(w) + 1 > width and cur:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    if cur:
        lines.append(cur)
    return "\n".join(lines[:5]) + ("…" if len(lines) > 5 else "")


def _color(graph: ScenarioGraph, nid: str) -> tuple[str, float]:
    n = graph.nodes[nid]
    base = COLORS["behavior"] if nid == graph.root else COLORS[n.kind]
    return (base, 1.0) if n.status in ("accepted", "pending") else (MUTED, 0.55)


def compact(graph: ScenarioGraph) -> ScenarioGraph:
    """The graph for a static picture: each entity's chosen property values become one node and
    its rejected values one muted summary node, so the picture stays readable; the interactive
    page keeps every node."""
    from regen.core.graph import Decision, Edge, Node, node_id

    g = graph.model_copy(deep=True)
    chosen: dict[str, list[str]] = {}
    dropped: dict[str, list[str]] = {}
    for n in list(g.nodes.values()):
        if n.kind != "property":
            continue
        target = next((e.target for e in g.edges if e.source == n.id), None)
        if target is None:
            continue
        (chosen if n.status == "accepted" else dropped).setdefault(target, []).append(n.label)
        del g.nodes[n.id]
    g.edges = [e for e in g.edges if e.source in g.nodes and e.target in g.nodes]
    for ent, labels in chosen.items():
        node = Node(id=node_id("property", "chosen", ent), kind="property", status="accepted",
                    label="; ".join(labels), history=[Decision(action="accepted", by="model")])
        g.nodes[node.id] = node
        g.edges.append(Edge(source=node.id, target=ent, kind="describes"))
    for ent, labels in dropped.items():
        node = Node(id=node_id("property", "not chosen", ent), kind="property", status="rejected",
                    label=f"not chosen ({len(labels)}): " + ", ".join(labels[:3]) + (" ..." if len(labels) > 3 else ""),
                    history=[Decision(action="rejected", by="model")])
        g.nodes[node.id] = node
        g.edges.append(Edge(source=node.id, target=ent, kind="describes", status="rejected"))
    return g


# --- graph.png: drawn with Pillow ----------------------------------------------------------

TEXT_PX, HEAD_PX, TITLE_PX, LEGEND_PX = 11, 13, 16, 12  # font sizes [px]
LINE_H = 14  # [px] between the lines of a box's text
PAD_X, PAD_Y = 9, 7  # [px] text to box edge
COL_GAP, ROW_GAP = 96, 22  # [px] between columns (room for arrows) and between rows
MARGIN = 24  # [px] around everything
MIN_WIDTH = 640  # [px] the narrowest picture (the title's room)
TOP = MARGIN + 30 + 28  # [px] the title and the column headings above the first row
LEGEND_H = 44  # [px] the legend band below the last row
SS = 2  # boxes and arrows drawn this many times larger, then halved
MAX_SUPERSAMPLED_PX = 24_000_000  # [px] a larger graph is drawn at its size (72 MB of RGB at most)
WHITE = (255, 255, 255)
EDGE, EDGE_REJECTED = (85, 85, 85), (200, 200, 200)
OUTLINE, OUTLINE_MUTED = (51, 51, 51), (153, 153, 153)
TEXT_MUTED, HEAD_TEXT = (68, 68, 68), (51, 51, 51)
ARROW_APART = 9  # [px] at most between the ends of arrows into one box
RADIUS = {"event": 9, "entity": 2, "property": 5}  # [px] corner radius of a box, by node kind


@dataclass(frozen=True)
class Box:
    """One node's box [px]: left, top, right, bottom, its text lines and colours."""

    node: str
    kind: str
    left: float
    top: float
    right: float
    bottom: float
    lines: tuple[str, ...]
    fill: tuple[int, int, int]
    muted: bool

    @property
    def middle(self) -> float:
        return (self.top + self.bottom) / 2


@dataclass(frozen=True)
class Arrow:
    """A cause -> effect edge [px]: from the source box's right edge to the target's left edge."""

    start: tuple[float, float]
    end: tuple[float, float]
    accepted: bool


@dataclass(frozen=True)
class PictureLayout:
    """Where everything of the picture goes: its size, the boxes by node id, the arrows, the
    column headings (centre x, text) and the title."""

    width: int
    height: int
    boxes: dict[str, Box]
    arrows: list[Arrow]
    headings: list[tuple[float, str]]
    title: str


def _fill(graph: ScenarioGraph, nid: str) -> tuple[tuple[int, int, int], bool]:
    color, alpha = _color(graph, nid)
    if alpha >= 1.0:
        return ImageColor.getrgb(color), False
    # a muted box: its grey laid over white at the alpha the matplotlib picture used
    return tuple(round(alpha * c + (1 - alpha) * 255) for c in ImageColor.getrgb(color)), True  # type: ignore[return-value]


def picture_layout(graph: ScenarioGraph) -> PictureLayout:
    """The picture of ``graph`` (rejected property values summarized, :func:`compact`) laid out."""
    graph = compact(graph)
    pos = layout(graph)
    font = media.text_font(TEXT_PX)
    sized: dict[str, tuple[tuple[str, ...], float, float]] = {}
    for nid in pos:
        n = graph.nodes[nid]
        label = _wrap(n.label, 30) if n.kind == "property" else _wrap(n.label)
        if n.status == "unsimulatable":
            label += "\n(not simulatable)"
        elif n.status == "rejected":
            label += "\n(rejected)"
        lines = tuple(_clean(label).split("\n"))
        w = max(media.text_length(line, font) for line in lines) + 2 * PAD_X
        sized[nid] = (lines, w, len(lines) * LINE_H + 2 * PAD_Y - 2)
    ncols = max(int(x) for x, _ in pos.values()) + 1
    col_w = [max((sized[n][1] for n, (x, _) in pos.items() if int(x) == c), default=0.0) for c in range(ncols)]
    lefts = [MARGIN + sum(col_w[:c]) + COL_GAP * c for c in range(ncols)]
    pitch = max(h for _, _, h in sized.values()) + ROW_GAP
    boxes = {}
    for nid, (x, y) in pos.items():
        lines, w, h = sized[nid]
        c = int(x)
        cx, cy = lefts[c] + col_w[c] / 2, TOP + pitch * (y + 0.5)
        fill, muted = _fill(graph, nid)
        boxes[nid] = Box(nid, graph.nodes[nid].kind, round(cx - w / 2), round(cy - h / 2), round(cx + w / 2),
                         round(cy + h / 2), lines, fill, muted)
    arrows = _arrows(graph, boxes)
    heads = ["properties", "entities"] + [f"causes (depth {d})" for d in range(ncols - 3, 0, -1)] + ["behavior"]
    headings = [(lefts[c] + col_w[c] / 2, h) for c, h in enumerate(heads[:ncols])]
    nrows = max(int(math.ceil(y + 0.5)) for _, y in pos.values())
    width = max(lefts[-1] + col_w[-1] + MARGIN, _legend_width() + 2 * MARGIN, MIN_WIDTH)
    # a long behavior is cut with an ellipsis to the picture's width; graph.html shows all of it
    title = media.fit_text(ImageDraw.Draw(Image.new("RGB", (1, 1))), f"Scenario graph: {_clean(graph.behavior.text)}",
                           media.text_font(TITLE_PX), width - 2 * MARGIN)
    return PictureLayout(int(math.ceil(width)), int(TOP + pitch * nrows + LEGEND_H + MARGIN), boxes, arrows,
                         headings, title)


def _arrows(graph: ScenarioGraph, boxes: dict[str, Box]) -> list[Arrow]:
    """An arrow per edge between drawn boxes; the arrows into one box end apart on its left edge,
    in the order of their sources from top to bottom, so their heads do not cover each other."""
    into: dict[str, list] = {}
    for e in graph.edges:
        if e.source in boxes and e.target in boxes:
            into.setdefault(e.target, []).append(e)
    arrows = []
    for target, edges in into.items():
        t = boxes[target]
        edges.sort(key=lambda e: (boxes[e.source].middle, boxes[e.source].left))
        step = min(ARROW_APART, 0.6 * (t.bottom - t.top) / max(len(edges) - 1, 1))
        for k, e in enumerate(edges):
            s = boxes[e.source]
            end_y = t.middle + (k - (len(edges) - 1) / 2) * step
            arrows.append(Arrow((s.right, s.middle), (t.left, end_y), e.status == "accepted"))
    return arrows


def draw_png(graph: ScenarioGraph, path: Path) -> Path:
    """Draw ``graph`` into the PNG ``path`` (atomically); returns ``path``."""
    if Path(path).suffix.lower() != ".png":
        raise ConfigError(f"{path}: the graph's picture is a PNG; give a path ending in .png "
                          "(graph.html is the scalable, interactive picture)")
    pic = picture_layout(graph)
    ss = SS if pic.width * pic.height * SS * SS <= MAX_SUPERSAMPLED_PX else 1
    shapes = Image.new("RGB", (pic.width * ss, pic.height * ss), WHITE)
    draw = ImageDraw.Draw(shapes)
    for a in sorted(pic.arrows, key=lambda a: a.accepted):  # accepted ones on top
        _arrow(draw, a, ss)
    for b in pic.boxes.values():
        _box(draw, b, ss)
    img = shapes.reduce(ss) if ss > 1 else shapes
    _texts(ImageDraw.Draw(img), pic)
    return media.write_png(path, img, compress_level=6)


def _arrow(draw: ImageDraw.ImageDraw, a: Arrow, ss: int) -> None:
    """``a`` on a drawing ``ss`` times the picture's size."""
    (x0, y0), (x1, y1) = ((x * ss, y * ss) for x, y in (a.start, a.end))
    length = math.hypot(x1 - x0, y1 - y0)
    if length < 1:
        return
    ux, uy = (x1 - x0) / length, (y1 - y0) / length
    head = (9 if a.accepted else 7) * ss
    half = head * 0.42
    bx, by = x1 - ux * head, y1 - uy * head  # the head's base: the line stops there
    color = EDGE if a.accepted else EDGE_REJECTED
    width = max(1, round(1.6 * ss)) if a.accepted else ss
    if a.accepted:
        draw.line([(x0, y0), (bx, by)], fill=color, width=width)
    else:  # dashed, as a rejected candidate is
        dash, gap = 6 * ss, 4 * ss
        along = 0.0
        while along < length - head:
            stop = min(along + dash, length - head)
            draw.line([(x0 + ux * along, y0 + uy * along), (x0 + ux * stop, y0 + uy * stop)], fill=color, width=width)
            along = stop + gap
    draw.polygon([(x1, y1), (bx - uy * half, by + ux * half), (bx + uy * half, by - ux * half)], fill=color)


def _box(draw: ImageDraw.ImageDraw, b: Box, ss: int) -> None:
    """``b`` on a drawing ``ss`` times the picture's size."""
    outline = OUTLINE_MUTED if b.muted else OUTLINE
    draw.rounded_rectangle([b.left * ss, b.top * ss, b.right * ss, b.bottom * ss], radius=RADIUS[b.kind] * ss,
                           fill=b.fill, outline=outline, width=ss)


def _texts(draw: ImageDraw.ImageDraw, pic: PictureLayout) -> None:
    font = media.text_font(TEXT_PX)
    for b in pic.boxes.values():
        color = TEXT_MUTED if b.muted else WHITE
        y = b.top + PAD_Y - 1
        for line in b.lines:
            w = media.text_length(line, font)
            draw.text(((b.left + b.right - w) / 2, y), line, fill=color, font=font)
            y += LINE_H
    title = media.text_font(TITLE_PX)
    draw.text(((pic.width - media.text_length(pic.title, title)) / 2, MARGIN), pic.title, fill=(20, 20, 20),
              font=title)
    head = media.text_font(HEAD_PX, bold=True)
    for x, text in pic.headings:
        draw.text((x - media.text_length(text, head) / 2, MARGIN + 34), text, fill=HEAD_TEXT, font=head)
    _legend(draw, pic)


def _legend_entries() -> list[tuple[tuple[int, int, int], str]]:
    return [(ImageColor.getrgb(COLORS[k]), k) for k in ("behavior", "event", "entity", "property")] + \
        [(ImageColor.getrgb(MUTED), "rejected / not simulatable")]


def _legend_step(text: str) -> float:
    """[px] from one legend entry's square to the next: square, gap, ``text``, gap."""
    return 14 + 6 + media.text_length(text, media.text_font(LEGEND_PX)) + 22


def _legend_width() -> float:
    return sum(_legend_step(text) for _, text in _legend_entries()) - 22


def _legend(draw: ImageDraw.ImageDraw, pic: PictureLayout) -> None:
    """Coloured squares with the node kinds, centred under the boxes."""
    font = media.text_font(LEGEND_PX)
    x = (pic.width - _legend_width()) / 2
    y = pic.height - MARGIN - 20
    for color, text in _legend_entries():
        draw.rectangle([round(x), y, round(x) + 13, y + 13], fill=color)
        draw.text((x + 20, y - 1), text, fill=HEAD_TEXT, font=font)
        x += _legend_step(text)


_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Scenario graph: {title}</title>
<style>
body{{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0;display:flex;height:100vh;color:#222}}
#canvas{{flex:1;overflow:auto;background:#fafafa}} #side{{width:340px;border-left:1px solid #ddd;padding:12px;overflow:auto;font-size:13px}}
.node rect{{stroke:#333;stroke-width:1}} .node.muted rect{{stroke:#999;stroke-dasharray:4 3}} .node{{cursor:pointer}}
.node text{{font-size:11px;pointer-events:none}} .edge{{stroke:#666;stroke-width:1.3;fill:none;marker-end:url(#arrow)}}
.edge.rejected{{stroke:#ccc;stroke-dasharray:5 4}} .node.sel rect{{stroke:#d62728;stroke-width:3}}
h1{{font-size:15px;margin:0 0 8px}} .legend span{{display:inline-block;padding:2px 6px;margin:2px;border-radius:3px;color:#fff;font-size:11px}}
li{{margin-bottom:6px}} .k{{color:#777}} label{{font-size:12px}}
</style></head><body>
<div id="canvas"><svg id="svg" xmlns="http://www.w3.org/2000/svg"></svg></div>
<div id="side"><h1>{title}</h1>
<div class="legend">{legend}</div>
<p class="k">Stopped: {stop}</p>
<label><input type="checkbox" id="showrej" checked> show rejected and unsimulatable events and entities</label><br>
<label><input type="checkbox" id="showvals"> show every rejected property value</label>
<div id="info"><p>Click a node to see who proposed, accepted or rejected it, and why.</p></div></div>
<script>
const G = {data};
const W = 230, H = 56, GX = 290, GY = 74, PAD = 30;
const svg = document.getElementById('svg');
const NS = 'http://www.w3.org/2000/svg';
function el(n, a) {{ const e = document.createElementNS(NS, n); for (const k in a) e.setAttribute(k, a[k]); return e; }}
function esc(s) {{ const d = document.createElement('div'); d.textContent = s; return d.innerHTML; }}
function draw() {{
  const showRej = document.getElementById('showrej').checked;
  const all = document.getElementById('showvals').checked;
  for (const id in G.nodes) {{ const n = G.nodes[id]; n.px = all ? n.x : n.cx; n.py = all ? n.y : n.cy; }}
  svg.innerHTML = '';
  const defs = el('defs', {{}}); const m = el('marker', {{id:'arrow', viewBox:'0 0 10 10', refX:'10', refY:'5', markerWidth:'7', markerHeight:'7', orient:'auto'}});
  m.appendChild(el('path', {{d:'M0,0 L10,5 L0,10 z', fill:'#666'}})); defs.appendChild(m); svg.appendChild(defs);
  let maxX = 0, maxY = 0;
  const vis = n => n.px !== null && (showRej || !n.muted);
  for (const e of G.edges) {{
    const a = G.nodes[e.source], b = G.nodes[e.target];
    if (!vis(a) || !vis(b)) continue;
    const x0 = PAD + a.px * GX + W, y0 = PAD + a.py * GY + H / 2, x1 = PAD + b.px * GX, y1 = PAD + b.py * GY + H / 2;
    svg.appendChild(el('path', {{d:`M${{x0}},${{y0}} C${{x0 + 30}},${{y0}} ${{x1 - 30}},${{y1}} ${{x1}},${{y1}}`, class:'edge ' + e.status}}));
  }}
  for (const id in G.nodes) {{
    const n = G.nodes[id]; if (!vis(n)) continue;
    const x = PAD + n.px * GX, y = PAD + n.py * GY; maxX = Math.max(maxX, x + W); maxY = Math.max(maxY, y + H);
    const g = el('g', {{class:'node' + (n.muted ? ' muted' : ''), 'data-id': id}});
    g.appendChild(el('rect', {{x, y, width:W, height:H, rx: n.kind === 'entity' ? 2 : 12, fill:n.color, 'fill-opacity': n.muted ? 0.45 : 1}}));
    const lines = n.lines;
    lines.forEach((t, i) => {{ const tx = el('text', {{x: x + 8, y: y + 16 + i * 13, fill: n.muted ? '#333' : '#fff'}}); tx.textContent = t; g.appendChild(tx); }});
    g.addEventListener('click', () => show(id, g));
    svg.appendChild(g);
  }}
  svg.setAttribute('width', maxX + PAD); svg.setAttribute('height', maxY + PAD);
}}
function show(id, g) {{
  document.querySelectorAll('.node.sel').forEach(x => x.classList.remove('sel')); g.classList.add('sel');
  const n = G.nodes[id];
  let h = `<h1>${{esc(n.label)}}</h1><p class="k">${{esc(n.kind)}} · ${{esc(n.status)}}</p><ol>`;
  for (const d of n.history) h += `<li><b>${{esc(d.action)}}</b> by ${{esc(d.by)}}${{d.call_id ? ' <span class="k">(call ' + esc(d.call_id.slice(0, 10)) + ')</span>' : ''}}<br>${{esc(d.reason || '')}}</li>`;
  document.getElementById('info').innerHTML = h + '</ol>';
}}
document.getElementById('showrej').addEventListener('change', draw);
document.getElementById('showvals').addEventListener('change', draw);
draw();
</script></body></html>
"""


def write_html(graph: ScenarioGraph, path: Path) -> Path:
    """An interactive page: click a node for its history. Self-contained, works offline."""
    pos = layout(graph)
    # a second layout without the rejected property values: the page opens with it, so the
    # causes are on screen first; a checkbox brings every rejected value back
    slim = graph.model_copy(deep=True)
    for nid in [n.id for n in slim.nodes.values() if n.kind == "property" and n.status != "accepted"]:
        del slim.nodes[nid]
    slim.edges = [e for e in slim.edges if e.source in slim.nodes and e.target in slim.nodes]
    slim_pos = layout(slim)
    nodes = {}
    for nid, (x, y) in pos.items():
        n = graph.nodes[nid]
        color, alpha = _color(graph, nid)
        label = n.label + (" (not simulatable)" if n.status == "unsimulatable" else
                           " (rejected)" if n.status == "rejected" else "")
        cx, cy = slim_pos.get(nid, (None, None))
        nodes[nid] = {"x": x, "y": y, "cx": cx, "cy": cy, "kind": n.kind, "status": n.status, "label": n.label,
                      "lines": _wrap(label, 34).split("\n")[:3], "color": color, "muted": alpha < 1,
                      "history": [d.model_dump() for d in n.history]}
    edges = [{"source": e.source, "target": e.target, "status": e.status} for e in graph.edges
             if e.source in pos and e.target in pos]
    # JSON inside <script>: escape '<' so no text can close the script element
    data = json.dumps(_clean({"nodes": nodes, "edges": edges})).replace("<", "\\u003c")
    legend = "".join(f'<span style="background:{c}">{k}</span>' for k, c in COLORS.items()) + \
        f'<span style="background:{MUTED};color:#333">rejected / not simulatable</span>'
    page = _PAGE.format(title=html.escape(_clean(graph.behavior.text)), legend=legend, data=data,
                        stop=html.escape(_clean(graph.stop_reason or "completed")))
    return atomic_write_text(path, page)
