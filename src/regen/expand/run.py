"""``regen expand`` as a library call: expand a graph and write JSON and pictures to a folder."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from regen.core.behavior import Behavior
from regen.core.graph import ScenarioGraph
from regen.core.io import write_json
from regen.errors import RunError
from regen.expand.expansion import Limits, expand
from regen.expand.pictures import draw_png, write_html
from regen.llm.client import LLM

log = logging.getLogger(__name__)


@dataclass
class ExpandResult:
    graph: ScenarioGraph
    files: dict[str, Path]


def save_graph(graph: ScenarioGraph, out: Path, *, pictures: bool = True) -> dict[str, Path]:
    files = {"graph": write_json(out / "graph.json", graph)}
    if pictures:
        files["png"] = draw_png(graph, out / "graph.png")
        files["html"] = write_html(graph, out / "graph.html")
    return files


def draw_graph_files(folder: str) -> list[str]:
    """graph.png and graph.html of the graph.json in ``folder``: the graph's pictures drawn where
    a task runs (a batch's worker), off the process that asks the model; the files written."""
    out = Path(folder)
    graph = load_graph(out / "graph.json")
    return [str(draw_png(graph, out / "graph.png")), str(write_html(graph, out / "graph.html"))]


def load_graph(path: Path) -> ScenarioGraph:
    try:
        return ScenarioGraph.model_validate_json(path.read_text("utf-8"))
    except (OSError, ValueError) as exc:
        raise RunError(f"cannot read the saved graph {path}: {exc}. Delete it to start the "
                       "expansion anew.") from None


def run_expand(behavior: Behavior, llm: LLM, out: Path, *, limits: Limits | None = None,
               prior: str | None = None, candidates: Sequence[str] = (),
               forced_causes: Sequence[str] = (),
               on_update: Callable[[ScenarioGraph, str], None] | None = None) -> ExpandResult:
    """Expand and save. The graph is saved after every step, so an interrupt or crash keeps it;
    a rerun replays cached model answers and so rebuilds the same graph quickly."""
    out.mkdir(parents=True, exist_ok=True)

    def saver(graph: ScenarioGraph, what: str) -> None:
        write_json(out / "graph.json", graph)
        if on_update:
            on_update(graph, what)

    graph = expand(behavior, llm, limits=limits, prior=prior, candidates=candidates,
                   forced_causes=forced_causes, on_update=saver)
    return ExpandResult(graph=graph, files=save_graph(graph, out))
