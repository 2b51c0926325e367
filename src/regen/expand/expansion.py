"""Graph expansion (paper Alg. 1): events backward from the behavior, then entities, then
properties, under stopping rules; everything the model said is kept on the graph."""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from regen.assets.database import AssetDatabase
from regen.core.behavior import Behavior
from regen.core.graph import Decision, Node, ScenarioGraph, node_id
from regen.core.text import one_line
from regen.expand import edges, properties
from regen.expand.dedupe import merge
from regen.llm.client import LLM

if TYPE_CHECKING:
    from regen.contract import DomainBackend

log = logging.getLogger(__name__)


@dataclass
class Limits:
    """Stopping rules and sizes. Calls and tokens count everything this client has done.

    These defaults are the toolkit's only ones: the main job's settings and both CLI commands
    take theirs from here (sized so the offline model finishes the README job in minutes).
    """

    max_depth: int = 1  # event layers behind the behavior
    max_nodes: int = 8  # accepted cause events (the behavior not counted)
    max_calls: int | None = None  # model calls (cache hits included)
    max_tokens: int | None = None  # input + output tokens
    max_causes: int = 3  # candidates per proposal call
    max_values: int = 3  # proposed values per free property
    max_entities: int = 2  # entities kept per event


class _Stop(Exception):
    def __init__(self, reason: str):
        self.reason = reason


class Expander:
    """Runs the three phases on one graph; ``on_update`` is called after each step (for saving)."""

    def __init__(self, llm: LLM, database: AssetDatabase, limits: Limits | None = None, *,
                 prior: str | None = None, on_update: Callable[[ScenarioGraph, str], None] | None = None,
                 should_stop: Callable[[], bool] | None = None, domain: edges.DomainView | None = None):
        self.llm = llm
        self.db = database
        self.domain = domain  # the graph's domain, looked up once (on the first graph when None)
        self.limits = limits or Limits()
        self.prior = prior
        self.on_update = on_update
        self.should_stop = should_stop

    def _domain(self, graph: ScenarioGraph) -> edges.DomainView:
        """The view of the graph's domain, made once."""
        if self.domain is None or self.domain.name != graph.behavior.domain:
            self.domain = edges.domain_view(graph.behavior.domain)
        return self.domain

    # --- budget -----------------------------------------------------------------------------

    def _check(self, graph: ScenarioGraph) -> None:
        lim, t = self.limits, self.llm.stats.total
        if self.should_stop and self.should_stop():
            raise _Stop("stopped by the caller")
        if lim.max_calls is not None and t.calls >= lim.max_calls:
            raise _Stop(f"max_calls ({lim.max_calls}) reached")
        if lim.max_tokens is not None and t.input_tokens + t.output_tokens >= lim.max_tokens:
            raise _Stop(f"max_tokens ({lim.max_tokens}) reached")

    def _events_full(self, graph: ScenarioGraph) -> bool:
        return len(graph.events()) - 1 >= self.limits.max_nodes

    def _notify(self, graph: ScenarioGraph, what: str) -> None:
        if self.on_update:
            self.on_update(graph, what)

    def chain(self, graph: ScenarioGraph, nid: str) -> list[str]:
        """Labels from ``nid`` down its first accepted effect chain to the behavior."""
        out, cur, seen = [graph.nodes[nid].label], nid, {nid}
        while cur != graph.root:
            nxt = next((e.target for e in graph.edges if e.source == cur and e.status == "accepted"
                        and e.kind == "causes" and e.target not in seen), None)
            if nxt is None:
                break
            out.append(graph.nodes[nxt].label)
            seen.add(nxt)
            cur = nxt
        return out

    # --- phase 1: events --------------------------------------------------------------------

    def _expand_one(self, graph: ScenarioGraph, nid: str, user: Sequence[str],
                    forced: Sequence[str] = ()) -> tuple:
        chain = self.chain(graph, nid)
        proposed, pid = edges.propose_events(self.llm, self._domain(graph), chain, prior=self.prior,
                                             max_causes=self.limits.max_causes)
        # insisted-on causes first, so a model proposal that duplicates one merges into the user's words
        everything = [*forced, *proposed, *user]
        existing = [n.label for n in graph.nodes.values() if n.kind == "event"]
        fresh, merged = merge(everything, existing, stop=self._domain(graph).wording.stop_words)
        judged = edges.judge_events(self.llm, self._domain(graph), chain, fresh) if fresh else None
        return nid, proposed, pid, [*forced, *user], fresh, merged, judged, list(forced)

    def _apply(self, graph: ScenarioGraph, result: tuple) -> list[str]:
        nid, proposed, pid, user, fresh, merged, judged, forced = result
        src = graph.nodes[nid]
        domain = self._domain(graph)
        new_ids: list[str] = []
        if not proposed and not user:
            src.history = src.history + [Decision(action="proposed", by="model", call_id=pid,
                                                  reason="the model proposed no causes")]
        for text, into in merged.items():
            target = graph.find("event", into)
            if target is not None and target.id != nid:
                # a duplicate of an event already in the graph: try to link the existing node
                self._link_existing(graph, target, src, text, pid, forced=text in forced)
            # duplicates among the new candidates are recorded on the kept one below
        insisted = {c for c in fresh if c in forced or any(merged.get(f) == c for f in forced)}
        for cand in fresh:
            by = "user" if cand in user and cand not in proposed else "model"
            node = graph.add_node(Node(
                id=node_id("event", cand), kind="event", label=cand, depth=src.depth + 1,
                history=[Decision(action="proposed", by=by, call_id=pid if by == "model" else None,
                                  reason=f"proposed as a cause of '{src.label}'")]))
            dups = [t for t, into in merged.items() if into == cand]
            if dups:
                node.history = node.history + [Decision(action="merged", by="rule",
                                                        reason="near-duplicates merged: " + "; ".join(dups))]
            assert judged is not None
            plausible = cand in judged.accepted
            opinion = judged.accepted[cand] if plausible else judged.rejected.get(cand, "not chosen")
            if cand in insisted:
                if self._accept(graph, node, nid, self._insisted(domain, cand, src.label, plausible, opinion,
                                                                 judged.call_for(cand))):
                    new_ids.append(node.id)
            elif plausible and (why := edges.ruled_out(domain, cand, src.label)):
                # the judge accepted it, but a rule rejects it (expand.edges.ruled_out)
                said = Decision(action="accepted", by="model", call_id=judged.call_for(cand), reason=opinion)
                self._reject(graph, node, nid, said)
                self._reject(graph, node, nid, Decision(action="rejected", by="rule", reason=why))
            elif plausible:
                if self._accept(graph, node, nid, Decision(action="accepted", by="model",
                                                           call_id=judged.call_for(cand), reason=opinion)):
                    new_ids.append(node.id)
            else:
                self._reject(graph, node, nid, Decision(action="rejected", by="model",
                                                        call_id=judged.call_for(cand), reason=opinion))
        return new_ids

    @staticmethod
    def _insisted(domain: edges.DomainView, cand: str, effect: str, plausible: bool, opinion: str,
                  call_id: str | None) -> Decision:
        """The user's acceptance of a cause given with --cause, carrying the judge's opinion."""
        reason = (f"given with --cause, accepted without judging; the judge said it is "
                  f"{'plausible' if plausible else 'implausible'}: {opinion}")
        if why := edges.ruled_out(domain, cand, effect):
            reason += f"; a rule would have rejected it: it {why}"
        return Decision(action="accepted", by="user", call_id=call_id, reason=reason)

    @staticmethod
    def _accept(graph: ScenarioGraph, node: Node, nid: str, decision: Decision) -> bool:
        """Accept ``node`` as a cause of ``nid``; False when that would close a cycle."""
        if graph.would_cycle(node.id, nid):
            graph.add_edge(node.id, nid, status="rejected", decision=Decision(
                action="rejected", by="rule", reason="would create a cycle"))
            return False
        node.status = "accepted"
        graph.add_edge(node.id, nid, decision=decision)
        node.history = node.history + [decision]
        return True

    @staticmethod
    def _reject(graph: ScenarioGraph, node: Node, nid: str, decision: Decision) -> None:
        """Record ``decision`` against ``node`` as a cause of ``nid`` (kept in the graph, marked)."""
        if node.status != "accepted":  # accepted as the cause of another event: it stays so
            node.status = "rejected"
        node.history = node.history + [decision]
        graph.add_edge(node.id, nid, status="rejected", decision=decision)

    def _link_existing(self, graph: ScenarioGraph, target: Node, src: Node, text: str, pid: str,
                       *, forced: bool = False) -> None:
        note = Decision(action="merged", by="rule", call_id=pid,
                        reason=f"'{text}' proposed as a cause of '{src.label}' duplicates this event")
        target.history = target.history + [note]
        if forced and target.status != "accepted":
            # the user insists on a cause the graph holds already, rejected: it is accepted now
            self._accept(graph, target, src.id, Decision(
                action="accepted", by="user", reason=f"given with --cause as '{text}'"))
            return
        if target.status != "accepted":
            return
        if graph.would_cycle(target.id, src.id):
            graph.add_edge(target.id, src.id, status="rejected", decision=Decision(
                action="rejected", by="rule", reason="would create a cycle"))
        else:
            graph.add_edge(target.id, src.id, decision=note)

    def expand_events(self, graph: ScenarioGraph, candidates: Sequence[str] = (),
                      forced_causes: Sequence[str] = ()) -> None:
        frontier = [n.id for n in graph.events() if not graph.causes_of(n.id)
                    and n.depth < self.limits.max_depth]
        first = True
        while frontier:
            if self._events_full(graph):
                raise _Stop(f"max_nodes ({self.limits.max_nodes}) reached")
            self._check(graph)
            user = list(candidates) if first else []
            forced = list(forced_causes) if first else []
            results = self.llm.map(
                lambda nid, user=user, forced=forced: self._expand_one(
                    graph, nid, *((user, forced) if nid == graph.root else ([], []))),
                frontier)
            nxt: list[str] = []
            for res in results:
                nxt.extend(self._apply(graph, res))
                if self._events_full(graph):
                    break
            self._notify(graph, "events")
            first = False
            frontier = [nid for nid in nxt if graph.nodes[nid].depth < self.limits.max_depth]
        graph.stop_reason = graph.stop_reason or f"max_depth ({self.limits.max_depth}) reached"

    # --- phase 2: entities ------------------------------------------------------------------

    def attach_entities(self, graph: ScenarioGraph) -> None:
        todo = [n for n in graph.events() if n.id != graph.root
                and not graph.causes_of(n.id, "entity")]
        if not todo:
            return
        self._check(graph)
        results = self.llm.map(
            lambda n: edges.select_entities(self.llm, self.db, self._domain(graph),
                                            self.chain(graph, n.id), behavior=graph.behavior), todo)
        for ev, judged in zip(todo, results, strict=True):
            rejected = [(name, why, "database") for name, why in judged.unknown.items()]
            rejected += [(name, why, "model" if name in judged.calls else "rule")
                         for name, why in judged.rejected.items()]
            for name, why, by in rejected:
                bad = graph.add_node(Node(
                    id=node_id("entity", name, ev.id), kind="entity", label=name, status="rejected",
                    history=[Decision(action="rejected", by=by, call_id=judged.call_for(name), reason=why)]))
                graph.add_edge(bad.id, ev.id, status="rejected", decision=bad.history[-1])
            chosen = list(judged.accepted.items())[: self.limits.max_entities]
            for name, reason in chosen:
                if name in judged.named:  # the event's words name it: the database decides
                    history = [Decision(action="accepted", by="database", reason=reason)]
                else:
                    history = [Decision(action="accepted", by="model", call_id=judged.call_for(name),
                                        reason=reason)]
                if name in judged.matched:
                    # the model used another name: an alias of the asset, or the closest asset
                    by, how = judged.matched[name]
                    history.insert(0, Decision(action="merged", by=by, call_id=judged.call_id, reason=how))
                ent = graph.add_node(Node(
                    id=node_id("entity", name, ev.id), kind="entity", label=name, asset=name,
                    status="accepted", depth=ev.depth, history=history))
                graph.add_edge(ent.id, ev.id, decision=ent.history[-1])
            if not chosen:
                ev.status = "unsimulatable"
                why = "no entity of the asset database can represent this event"
                if judged.unknown and not judged.call_id:  # decided before any model call
                    why += f": {'; '.join(judged.unknown.values())}"
                elif judged.unknown:
                    why += f" (the model asked for: {', '.join(judged.unknown)})"
                if judged.rejected:
                    why += f" (rejected: {'; '.join(judged.rejected.values())})"
                ev.history = ev.history + [Decision(action="marked_unsimulatable",
                                                    by="model" if judged.call_id else "database",
                                                    call_id=judged.call_id or None, reason=why)]
        self._notify(graph, "entities")

    # --- phase 3: properties ----------------------------------------------------------------

    def _entity_properties(self, graph: ScenarioGraph, ent: Node) -> tuple:
        ev = next(graph.nodes[e.target] for e in graph.edges
                  if e.source == ent.id and e.status == "accepted")
        chain = self.chain(graph, ev.id)
        domain = self._domain(graph)
        asset = ent.asset or ent.label
        params = self.db.parameters_of(asset)
        free = [(p, self.db.properties[p].description) for p in params
                if self.db.property_candidates(asset, p) is None]
        proposed: dict[str, list[str]] = {}
        pid = None
        if free:
            proposed, pid = properties.propose_values(self.llm, domain, chain, ev.label, asset, free,
                                                      max_values=self.limits.max_values)
        options = properties.property_options(self.db, asset, proposed)
        judged: dict[str, edges.Judged] = {}
        if options:
            named = properties.named_states(self.db, asset, ev.label, options,
                                            domain.own_objects(graph.behavior))
            judged, _ = properties.select_properties(self.llm, domain, chain, ev.label, asset, options,
                                                     domain.property_choices(asset, graph.behavior), named)
        return ent.id, proposed, pid, judged

    def attach_properties(self, graph: ScenarioGraph) -> None:
        ents = [n for n in graph.nodes.values() if n.kind == "entity" and n.status == "accepted"
                and not graph.causes_of(n.id, "property")]
        if not ents:
            return
        self._check(graph)
        results = self.llm.map(lambda n: self._entity_properties(graph, n), ents)
        for eid, proposed, pid, judged in results:
            for prop, jd in judged.items():
                for value, reason in jd.accepted.items():
                    if value in jd.named:  # no call: nothing was left to choose
                        decision = Decision(action="accepted", by="database", reason=reason)
                    else:
                        decision = Decision(action="accepted", by="model", call_id=jd.call_id, reason=reason)
                    self._prop_node(graph, eid, prop, value, "accepted", proposed, pid, decision)
                for value, reason in jd.rejected.items():
                    self._prop_node(graph, eid, prop, value, "rejected", proposed, pid,
                                    Decision(action="rejected", by="model", call_id=jd.call_id, reason=reason))
                for value, reason in jd.ruled.items():
                    self._prop_node(graph, eid, prop, value, "rejected", proposed, pid,
                                    Decision(action="rejected", by="rule", reason=reason))
                for value, reason in jd.unknown.items():
                    self._prop_node(graph, eid, prop, value, "rejected", proposed, pid,
                                    Decision(action="rejected", by="database", call_id=jd.call_id, reason=reason))
        self._notify(graph, "properties")

    def _prop_node(self, graph: ScenarioGraph, eid: str, prop: str, value: str, status: str,
                   proposed: dict[str, list[str]], pid: str | None, decision: Decision) -> None:
        origin = (Decision(action="proposed", by="model", call_id=pid, reason="proposed value")
                  if value in proposed.get(prop, []) else
                  Decision(action="proposed", by="database", reason=f"a value of {prop} in the database"))
        node = graph.add_node(Node(id=node_id("property", f"{prop}={value}", eid), kind="property",
                                   label=f"{prop} = {value}", property=prop, value=value,
                                   status=status, history=[origin, decision]))  # type: ignore[arg-type]
        graph.add_edge(node.id, eid, status="accepted" if status == "accepted" else "rejected",
                       decision=decision)

    # --- all --------------------------------------------------------------------------------

    def run(self, graph: ScenarioGraph, candidates: Sequence[str] = (),
            forced_causes: Sequence[str] = ()) -> ScenarioGraph:
        try:
            try:
                self.expand_events(graph, candidates, forced_causes)
            except _Stop as stop:
                graph.stop_reason = stop.reason
            # entities and properties for what the event phase found (budget permitting)
            self.attach_entities(graph)
            self.attach_properties(graph)
        except _Stop as stop:
            graph.stop_reason = f"{graph.stop_reason}; then {stop.reason}" if graph.stop_reason else stop.reason
        except KeyboardInterrupt:
            graph.stop_reason = "interrupted by the user (the graph built so far is kept)"
            log.warning("expansion interrupted; keeping the partial graph")
        self._notify(graph, "done")
        return graph


def expand(behavior: Behavior, llm: LLM, *, database: AssetDatabase | None = None,
           limits: Limits | None = None, prior: str | None = None, candidates: Sequence[str] = (),
           forced_causes: Sequence[str] = (),
           on_update: Callable[[ScenarioGraph, str], None] | None = None,
           should_stop: Callable[[], bool] | None = None,
           graph: ScenarioGraph | None = None, backend: DomainBackend | None = None) -> ScenarioGraph:
    """Expand a scenario graph backward from ``behavior`` (paper Alg. 1).

    Args:
        behavior: the input behavior (its text is the root event).
        llm: the model client (cached; concurrency from the client).
        database: asset database; the domain's built-in one by default.
        limits: stopping rules (depth, nodes, calls, tokens) and sizes.
        prior: optional natural-language prior for event proposal (e.g. 'police car').
        candidates: user-given candidate causes of the behavior, judged with the model's (a
            rejected one stays in the graph with the judge's reason).
        forced_causes: user-given causes of the behavior accepted whatever the judge says (it is
            still asked; its opinion is kept in the node's history), then expanded like any other.
        on_update: called with the graph after each phase step (to save it).
        should_stop: polled before each step; True stops expansion gracefully.
        graph: continue a saved graph instead of starting anew.
        backend: the behavior domain's backend when the caller has one (else made here, once);
            every proposal and judgement takes the domain's words from it.
    """
    domain = (edges.domain_view(behavior.domain) if backend is None
              else edges.DomainView(behavior.domain, backend))
    if database is None:
        database = domain.database()
    g = graph or ScenarioGraph.start(behavior)
    if prior is not None:
        prior = one_line(prior) or None
    return Expander(llm, database, limits, prior=prior, on_update=on_update, should_stop=should_stop,
                    domain=domain).run(g, _tidy(candidates), _tidy(forced_causes))


def _tidy(texts: Sequence[str]) -> list[str]:
    """User-given causes without invisible characters (regen.core.text), their whitespace
    collapsed; blank ones dropped."""
    out = (one_line(t) for t in texts if t)
    return [t for t in out if t]
