"""The scenario graph (paper Alg. 1): events, entities and properties with typed edges.

Edges point from cause to effect: event -> event (cause -> effect), entity -> event (the
entity takes part in the event), property -> entity (the property supports the entity's role).
Accepted edges form a DAG; rejected candidates stay in the graph, marked, with the reason, so a
user can audit why each node exists or does not.
"""

from __future__ import annotations

import hashlib
from typing import Literal

import networkx as nx
from pydantic import Field, model_validator
from pydantic_core import to_json

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.errors import GraphCycleError, GraphError

NodeKind = Literal["event", "entity", "property"]
NodeStatus = Literal["accepted", "rejected", "unsimulatable", "pending"]
EdgeKind = Literal["causes", "participates", "describes"]

EDGE_KINDS: dict[tuple[str, str], str] = {
    ("event", "event"): "causes",
    ("entity", "event"): "participates",
    ("property", "entity"): "describes",
}


class Decision(Model):
    """One step of a node's or edge's history: who said what about it, and why."""

    action: Literal["proposed", "accepted", "rejected", "merged", "marked_unsimulatable"]
    by: Literal["model", "user", "database", "rule"]
    call_id: str | None = None  # cache key of the model call, when a model decided
    reason: str = ""


class Node(Model):
    id: str
    kind: NodeKind
    label: str
    status: NodeStatus = "pending"
    depth: int = 0  # event depth from the behavior node (behavior = 0)
    asset: str | None = None  # entity nodes: the asset database id
    property: str | None = None  # property nodes: the property name (e.g. 'siren')
    value: str | None = None  # property nodes: the chosen value (e.g. 'on')
    history: list[Decision] = Field(default_factory=list)


class Edge(Model):
    source: str
    target: str
    kind: EdgeKind
    status: Literal["accepted", "rejected"] = "accepted"
    history: list[Decision] = Field(default_factory=list)


class PathEntity(Model):
    """An entity on a cause path with the property values the graph selected for it."""

    asset: str
    event: str  # label of the event it takes part in
    properties: dict[str, list[str]] = Field(default_factory=dict)


class CausePath(Model):
    """One fully simulatable chain of events (root cause first, behavior last): grounding's input."""

    behavior: Behavior
    events: list[str] = Field(min_length=1)
    entities: list[PathEntity] = Field(default_factory=list)

    def variants(self, limit: int = 4) -> list[CausePath]:
        """One path per combination of property values (the graph may accept several values of a
        property, e.g. two start locations): same cause, different properties. At most ``limit``,
        in a stable order; a path with single values is its own only variant."""
        import itertools

        slots = [(i, prop, vals) for i, e in enumerate(self.entities)
                 for prop, vals in e.properties.items() if len(vals) > 1]
        if not slots:
            return [self]
        out: list[CausePath] = []
        for combo in itertools.islice(itertools.product(*(vals for _, _, vals in slots)), limit):
            ents = [e.model_copy(deep=True) for e in self.entities]
            for (i, prop, _), value in zip(slots, combo, strict=True):
                ents[i].properties[prop] = [value]
            out.append(self.model_copy(update={"entities": ents}))
        return out

    @property
    def key(self) -> str:
        """A stable short id for the path (used as the scenario folder name suffix). The behavior
        is hashed in its layout of before ``Behavior.params`` (:meth:`Behavior.hash_layout`), so
        the keys, and the scenario ids, folders and seeds made from them, are the same as then."""
        data = self.model_dump(mode="json")
        data["behavior"] = self.behavior.hash_layout()
        return hashlib.sha256(to_json(data)).hexdigest()[:10]


def node_id(kind: str, label: str, parent: str | None = None) -> str:
    """Deterministic node id from its kind, label and (for entities/properties) its parent."""
    basis = f"{kind}|{parent or ''}|{' '.join(label.lower().split())}"
    return f"{kind[:3]}-{hashlib.sha1(basis.encode()).hexdigest()[:8]}"


class ScenarioGraph(Model):
    behavior: Behavior
    root: str  # id of the behavior node
    nodes: dict[str, Node] = Field(default_factory=dict)
    edges: list[Edge] = Field(default_factory=list)
    stop_reason: str | None = None  # why expansion stopped (depth, nodes, calls, interrupt, ...)

    @classmethod
    def start(cls, behavior: Behavior) -> ScenarioGraph:
        root = Node(id=node_id("event", behavior.text), kind="event", label=behavior.text,
                    status="accepted", depth=0,
                    history=[Decision(action="proposed", by="user", reason="input behavior")])
        return cls(behavior=behavior, root=root.id, nodes={root.id: root})

    @model_validator(mode="after")
    def _check(self) -> ScenarioGraph:
        if self.root not in self.nodes:
            raise GraphError(f"the root node {self.root!r} is not among the graph's nodes")
        for e in self.edges:
            for end in (e.source, e.target):
                if end not in self.nodes:
                    raise GraphError(f"edge {e.source} -> {e.target} names unknown node {end!r}")
            kinds = (self.nodes[e.source].kind, self.nodes[e.target].kind)
            if EDGE_KINDS.get(kinds) != e.kind:
                raise GraphError(f"edge {e.source} -> {e.target} of kind {e.kind!r} cannot join "
                                 f"a {kinds[0]} node to a {kinds[1]} node")
        g = self.digraph()
        if not nx.is_directed_acyclic_graph(g):
            cycle = nx.find_cycle(g)
            raise GraphCycleError("the causal graph has a cycle: " + " -> ".join(
                self.nodes[a].label for a, _ in cycle) + "; remove one of these edges")
        return self

    # --- queries ------------------------------------------------------------------------------

    def digraph(self, include_rejected: bool = False) -> nx.DiGraph:
        """The graph as networkx, over accepted edges (and their nodes) unless asked otherwise."""
        g = nx.DiGraph()
        for n in self.nodes.values():
            if include_rejected or n.status in ("accepted", "unsimulatable", "pending"):
                g.add_node(n.id, kind=n.kind, label=n.label, status=n.status)
        for e in self.edges:
            if include_rejected or e.status == "accepted":
                g.add_edge(e.source, e.target, kind=e.kind, status=e.status)
        return g

    def find(self, kind: NodeKind, label: str, parent: str | None = None) -> Node | None:
        return self.nodes.get(node_id(kind, label, parent))

    def causes_of(self, nid: str, kind: NodeKind = "event") -> list[Node]:
        return [self.nodes[e.source] for e in self.edges
                if e.target == nid and e.status == "accepted" and self.nodes[e.source].kind == kind]

    def events(self, status: NodeStatus | None = "accepted") -> list[Node]:
        return [n for n in self.nodes.values() if n.kind == "event"
                and (status is None or n.status == status)]

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for n in self.nodes.values():
            key = f"{n.kind}:{n.status}"
            out[key] = out.get(key, 0) + 1
        return out

    # --- mutation (used by expansion) ---------------------------------------------------------

    def add_node(self, node: Node) -> Node:
        """Add a node, or merge the history into the existing node with the same id."""
        existing = self.nodes.get(node.id)
        if existing is None:
            self.nodes[node.id] = node
            return node
        existing.history = existing.history + node.history
        return existing

    def would_cycle(self, source: str, target: str) -> bool:
        if source == target:
            return True
        g = self.digraph()
        return g.has_node(source) and g.has_node(target) and nx.has_path(g, target, source)

    def add_edge(self, source: str, target: str, *, status: Literal["accepted", "rejected"] = "accepted",
                 decision: Decision | None = None) -> Edge:
        """Add a typed edge; an accepted edge that would close a cycle raises GraphCycleError."""
        kinds = (self.nodes[source].kind, self.nodes[target].kind)
        kind = EDGE_KINDS.get(kinds)
        if kind is None:
            raise GraphError(f"no edge type joins a {kinds[0]} node to a {kinds[1]} node")
        if status == "accepted" and self.would_cycle(source, target):
            raise GraphCycleError(f"the edge '{self.nodes[source].label}' -> "
                                  f"'{self.nodes[target].label}' would make the graph cyclic")
        for e in self.edges:
            if e.source == source and e.target == target:
                if decision:
                    e.history = e.history + [decision]
                if status == "accepted":
                    e.status = "accepted"
                return e
        edge = Edge(source=source, target=target, kind=kind, status=status,  # type: ignore[arg-type]
                    history=[decision] if decision else [])
        self.edges.append(edge)
        return edge

    # --- paths: the input of grounding --------------------------------------------------------

    def paths(self) -> list[CausePath]:
        """Every chain of accepted events from a root cause to the behavior whose events are all
        simulatable (each has at least one accepted entity), with entities and properties."""
        g = nx.DiGraph()
        for e in self.edges:
            # unsimulatable causes drop out here, so the simulatable rest of a chain remains
            if (e.status == "accepted" and e.kind == "causes"
                    and self.nodes[e.source].status == "accepted"
                    and self.nodes[e.target].status == "accepted"):
                g.add_edge(e.source, e.target)
        g.add_node(self.root)
        out: list[CausePath] = []
        sources = [n for n in g.nodes if g.in_degree(n) == 0 and n != self.root]
        chains: list[list[str]] = []
        for s in sorted(sources, key=lambda n: self.nodes[n].label):
            chains.extend(nx.all_simple_paths(g, s, self.root))
        for chain in chains:
            causes = chain[:-1]
            if not causes:
                continue
            entities: list[PathEntity] = []
            ok = True
            for c in causes:
                ents = self.causes_of(c, "entity")
                if not ents:
                    ok = False
                    break
                for ent in ents:
                    props: dict[str, list[str]] = {}
                    for p in self.causes_of(ent.id, "property"):
                        if p.property and p.value is not None:
                            props.setdefault(p.property, []).append(p.value)
                    entities.append(PathEntity(asset=ent.asset or ent.label,
                                               event=self.nodes[c].label, properties=props))
            if ok:
                out.append(CausePath(behavior=self.behavior,
                                     events=[self.nodes[c].label for c in chain],
                                     entities=entities))
        return out
