"""What the ``regen falsify`` tests share: the driving run's scenario name, the graph's other
cause, and writing a run's run.json and graph.json by hand."""

from __future__ import annotations

from pathlib import Path

CHILD = "01-child-crosses"
OTHER_CAUSE = "a road worker crosses the road"  # the graph's other root cause (names road_worker)


def write_run(run: Path, path, names: list[str], causes: list[str]) -> None:
    """run.json listing ``names`` and a graph.json whose root causes are ``causes``."""
    from regen.core.graph import Node, ScenarioGraph, node_id
    from regen.core.io import write_json
    from regen.runfolder import RunFolder, RunManifest, RunSettings

    RunFolder(run).write_manifest(RunManifest(behavior=path.behavior, settings=RunSettings(llm="none"),
                                              scenarios=names, status="done"))
    graph = ScenarioGraph.start(path.behavior)
    for label in causes:
        node = graph.add_node(Node(id=node_id("event", label), kind="event", label=label, status="accepted", depth=1))
        graph.add_edge(node.id, graph.root)
    write_json(run / RunFolder.GRAPH, graph)


__all__ = ["CHILD", "OTHER_CAUSE", "write_run"]
