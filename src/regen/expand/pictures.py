"""Pictures of a scenario graph: a static PNG/SVG (matplotlib) and an interactive HTML page that
works offline (inline SVG and script, no CDN). Node kinds have distinct colors and shapes;
rejected and unsimulatable nodes stay visible but muted, so the audit trail can be seen."""

from __future__ import annotations

import html
import json
from pathlib import Path

from regen.core.graph import ScenarioGraph
from regen.core.io import atomic_write_text
from regen.core.text import clean_data

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


def draw_png(graph: ScenarioGraph, path: Path, *, dpi: int = 110) -> Path:
    """Static picture of the graph (PNG or SVG by suffix), rejected property values summarized."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    graph = compact(graph)
    pos = layout(graph)
    ncols = max(int(x) for x, _ in pos.values()) + 1
    nrows = max(int(y) for _, y in pos.values()) + 1
    fig, ax = plt.subplots(figsize=(max(8.0, 3.2 * ncols), max(4.5, 0.95 * nrows + 1.5)))
    for e in graph.edges:
        (x0, y0), (x1, y1) = pos[e.source], pos[e.target]
        ok = e.status == "accepted"
        ax.annotate("", xy=(x1 - 0.33, y1), xytext=(x0 + 0.33, y0),
                    arrowprops=dict(arrowstyle="-|>", color="#555555" if ok else "#CCCCCC",
                                    lw=1.3 if ok else 0.8, linestyle="-" if ok else "--",
                                    shrinkA=0, shrinkB=0))
    for nid, (x, y) in pos.items():
        n = graph.nodes[nid]
        color, alpha = _color(graph, nid)
        style = {"event": "round,pad=0.35", "entity": "square,pad=0.35", "property": "round4,pad=0.3"}[n.kind]
        label = _wrap(n.label, 30) if n.kind == "property" else _wrap(n.label)
        if n.status == "unsimulatable":
            label += "\n(not simulatable)"
        elif n.status == "rejected":
            label += "\n(rejected)"
        # parse_math off: a model's '$x^$' is text, not a formula that fails to parse
        ax.text(x, y, _clean(label), ha="center", va="center", fontsize=7.5, parse_math=False,
                color="white" if alpha == 1.0 else "#444444",
                bbox=dict(boxstyle=style, fc=color, ec="#333333" if alpha == 1.0 else "#999999",
                          lw=1.0, alpha=alpha, linestyle="-" if alpha == 1.0 else "--"))
    ax.set_xlim(-0.6, ncols - 0.4)
    ax.set_ylim(nrows - 0.4, -0.8)
    ax.axis("off")
    heads = ["properties", "entities"] + [f"causes (depth {d})" for d in range(ncols - 3, 0, -1)] + ["behavior"]
    for c, h in enumerate(heads[:ncols]):
        ax.text(c, -0.65, h, ha="center", va="center", fontsize=9, weight="bold", color="#333333")
    legend = [Line2D([0], [0], marker="s", color="w", markerfacecolor=COLORS[k], markersize=10, label=k)
              for k in ("behavior", "event", "entity", "property")]
    legend.append(Line2D([0], [0], marker="s", color="w", markerfacecolor=MUTED, markersize=10,
                         label="rejected / not simulatable"))
    ax.legend(handles=legend, loc="lower center", bbox_to_anchor=(0.5, -0.08), ncol=5, fontsize=8, frameon=False)
    ax.set_title(f"Scenario graph: {_clean(graph.behavior.text)}", fontsize=11, parse_math=False)
    fig.tight_layout()
    # tight_layout leaves a placeholder layout engine behind, for which savefig draws the whole
    # figure once more before drawing it into the file: a third of the picture's time, no pixel
    fig.set_layout_engine(None)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


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
