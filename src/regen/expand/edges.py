"""Node proposal and edge construction: the model calls of graph expansion (paper 2.1).

Each function makes one model call and returns plain data plus the call id, so the caller can
record who proposed, accepted or rejected what. Edge construction judges all candidates of one
source node in one call, not pairwise.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Union

from regen.assets.database import MATCH_THRESHOLD, AssetDatabase
from regen.core.behavior import Behavior
from regen.core.words import lowered, name_words
from regen.embeddings import optional_encoder
from regen.errors import ConfigError
from regen.expand.answers import EdgeVerdict, EntitySelection, EventProposal, YesNo
from regen.expand.calibration import ANSWER_PREFIX, threshold_for
from regen.expand.dedupe import normalize, similar
from regen.expand.rules import happens_elsewhere, opposite_of
from regen.llm.client import LLM
from regen.templates import render

if TYPE_CHECKING:
    from regen.contract import DomainBackend, PropertyChoices, Wording

PKG = "regen.expand"


@dataclass
class Judged:
    """The outcome of one edge-construction call."""

    call_id: str
    accepted: dict[str, str] = field(default_factory=dict)  # candidate -> reason
    rejected: dict[str, str] = field(default_factory=dict)  # candidate -> reason
    unknown: dict[str, str] = field(default_factory=dict)  # names the model gave that were not offered
    ruled: dict[str, str] = field(default_factory=dict)  # candidate -> why a rule rejected it unasked
    # accepted candidate -> (who matched the model's name to it: 'database' for an alias, 'rule'
    # for a similarity guess, and how)
    matched: dict[str, tuple[str, str]] = field(default_factory=dict)
    calls: dict[str, str] = field(default_factory=dict)  # candidate -> the call that judged it alone
    # accepted candidate -> why the database decided it (the event's words name it)
    named: dict[str, str] = field(default_factory=dict)

    def call_for(self, candidate: str) -> str:
        """The id of the call that decided ``candidate``."""
        return self.calls.get(candidate, self.call_id)


@dataclass(frozen=True, eq=False)
class DomainView:
    """One domain as expansion sees it: its backend, made once and handed down, so a proposal
    or a judgement never goes back to the registry. Every function here takes one (or, for
    callers outside expansion, the domain's name)."""

    name: str  # as registered (``--domain``)
    backend: DomainBackend

    @property
    def wording(self) -> Wording:
        """The domain's words in the shared prompts."""
        return self.backend.wording

    @property
    def robot_names(self) -> tuple[str, ...]:
        """Every phrase a cause may use for the robot itself (they name no asset)."""
        return (self.robot, *self.wording.robot_names)

    @property
    def robot(self) -> str:
        """What the domain calls the robot whose behavior is explained ('robot', 'ego-vehicle')."""
        return self.backend.report_hints.robot

    @cached_property
    def system(self) -> str:
        """The system prompt of every expansion call."""
        return render_prompt("system", self)

    @cached_property
    def mechanics(self) -> tuple[re.Pattern[str], ...]:
        """``Wording.mechanics`` compiled; ConfigError naming the domain for a bad pattern."""
        out = []
        for p in self.wording.mechanics:
            try:
                out.append(re.compile(p))
            except re.error as exc:
                raise ConfigError(f"domain {self.name!r}: Wording.mechanics pattern {p!r} is not a valid "
                                  f"regular expression ({exc})") from None
        return tuple(out)

    def database(self) -> AssetDatabase:
        return self.backend.database()

    def property_choices(self, asset: str, behavior: Behavior | None = None) -> PropertyChoices | None:
        return self.backend.property_choices(asset, behavior)

    def own_objects(self, behavior: Behavior | None) -> frozenset[str]:
        return self.backend.own_objects(behavior) if behavior is not None else frozenset()


Domain = Union[str, DomainView]  # noqa: UP007  (a domain's name, or its view)


def domain_view(domain: str | DomainView | DomainBackend) -> DomainView:
    """The view of a domain given by name (looked up in the registry once), view or backend."""
    if isinstance(domain, DomainView):
        return domain
    if isinstance(domain, str):
        from regen import domains

        return DomainView(domain, domains.make(domain))
    return DomainView(domain.name, domain)


def render_prompt(name: str, domain: DomainView, **variables: object) -> str:
    """A shared prompt in the words of ``domain`` (its backend's ``wording``)."""
    return render(PKG, name, wording=domain.wording, **variables)


def system_prompt(domain: Domain) -> str:
    return domain_view(domain).system


def robot_word(domain: Domain) -> str:
    """What the domain calls the robot whose behavior is explained ('robot', 'ego-vehicle')."""
    return domain_view(domain).robot


def restates_mechanics(domain: Domain, cause: str) -> str | None:
    """The words of ``cause`` that restate the robot's own command, programming, sensors or
    mechanics (the domain's ``Wording.mechanics``), or None for a context of the world."""
    text = lowered(cause)
    for rx in domain_view(domain).mechanics:
        if m := rx.search(text):
            return m.group(0).strip() or text
    return None


def ruled_out(domain: Domain, cause: str, effect: str | None = None) -> str | None:
    """Why a rule rejects ``cause`` (of ``effect``) whatever the judge says, or None: it is the
    robot's own doing, happens elsewhere or makes the opposite happen (:mod:`regen.expand.rules`)."""
    domain = domain_view(domain)
    if words := restates_mechanics(domain, cause):
        return (f"restates the {domain.robot}'s own command, programming or mechanics ('{words}'), "
                "not a context in which it acts")
    if words := happens_elsewhere(cause):
        return f"happens somewhere else ('{words}'): too far away to cause what the {domain.robot} does"
    if effect and (got := opposite_of(cause, effect, domain.wording.opposites, domain.robot_names)):
        return f"makes the opposite happen ('{got[0]}' {got[1]})"
    return None


def _match(name: str, options: list[str], stop: tuple[str, ...] = ()) -> str | None:
    """The option a model-written name refers to (exact, normalized, or near-duplicate;
    ``stop``: the domain's stop words)."""
    if name in options:
        return name
    n = normalize(name).replace(" ", "_")
    for o in options:
        if normalize(o).replace(" ", "_") == n:
            return o
    for o in options:
        if similar(name, o, threshold=0.9, stop=stop):
            return o
    return None


def propose_events(llm: LLM, domain: Domain, chain: list[str], *, prior: str | None = None,
                   max_causes: int = 4) -> tuple[list[str], str]:
    """Candidate causes of ``chain[0]`` (chain runs from the source node to the behavior)."""
    domain = domain_view(domain)
    prompt = render_prompt("event_proposal", domain, chain=chain, source=chain[0],
                           prior=prior, max_causes=max_causes)
    got = llm.ask(prompt, EventProposal, purpose="event_proposal", system=domain.system)
    return got.value.causes[:max_causes], got.call_id


def event_question(domain: Domain, chain: list[str], candidate: str) -> str:
    """The event judge's question: is ``candidate`` a direct reason for ``chain[0]``?"""
    domain = domain_view(domain)
    return render_prompt("event_edge", domain, chain=chain, source=chain[0], candidate=candidate, robot=domain.robot)


def judge_events(llm: LLM, domain: Domain, chain: list[str], candidates: list[str]) -> Judged:
    """Which candidates plausibly and directly cause ``chain[0]``: one yes/no call per candidate.

    Each call restates the effect as a question about that one candidate, with the domain's
    worked examples (``Wording.judge_examples``); a small model judges one short question far
    better than a list of them at once. A model with a calibrated threshold
    (:mod:`regen.expand.calibration`) is decided by its probability of yes; others by their
    written answer and reason.
    """
    domain = domain_view(domain)
    threshold = threshold_for(llm.provider.id) if llm.can_weigh else None
    if threshold is not None:
        return _weigh_events(llm, domain, chain, candidates, threshold)

    def ask(candidate: str):
        return llm.ask(event_question(domain, chain, candidate), EdgeVerdict, purpose="event_edges",
                       system=domain.system)

    answers = llm.map(ask, candidates)
    out = Judged(call_id=answers[0].call_id if answers else "")
    for c, got in zip(candidates, answers, strict=True):
        out.calls[c] = got.call_id
        reason = " ".join(got.value.reason.split())
        if got.value.answer == "yes":
            out.accepted[c] = reason or "plausible direct cause"
        else:
            out.rejected[c] = reason or "judged implausible"
    return out


def _weigh_events(llm: LLM, domain: DomainView, chain: list[str], candidates: list[str],
                  threshold: float) -> Judged:
    """The event judge of a calibrated model: the same question, decided by the model's
    probability of 'yes' against the threshold chosen on the tune half (:mod:`.calibration`)."""
    def weigh(candidate: str):
        return llm.weigh(event_question(domain, chain, candidate), ("yes", "no"), prefix=ANSWER_PREFIX,
                         purpose="event_edges", system=domain.system)

    answers = llm.map(weigh, candidates)
    out = Judged(call_id=answers[0].call_id if answers else "")
    for c, got in zip(candidates, answers, strict=True):
        out.calls[c] = got.call_id
        p = got.value["yes"]
        if p >= threshold:
            out.accepted[c] = f"the judge's P(yes) = {p:.2f} reaches its calibrated threshold {threshold:.2f}"
        else:
            out.rejected[c] = f"the judge's P(yes) = {p:.2f} is below its calibrated threshold {threshold:.2f}"
    return out


def named_entities(db: AssetDatabase, domain: Domain, event: str, *, own: frozenset[str] = frozenset()
                   ) -> dict[str, str]:
    """Asset -> why, for the assets ``event``'s words name (:meth:`AssetDatabase.named_assets`,
    the robot's own name excluded, close paraphrases included when the sentence-embedding model
    is installed); ``own``: the robot's task objects, never named here."""
    view = domain_view(domain)
    return db.named_assets(event, robot=view.robot_names, own=own, encoder=optional_encoder())


def judge_entity(llm: LLM, db: AssetDatabase, domain: Domain, event: str, asset: str):
    """One yes/no call: does ``asset`` take part in ``event``? (with the domain's worked examples)"""
    domain = domain_view(domain)
    prompt = render_prompt("entity_edge", domain, event=event, entity=asset,
                           description=db.assets[asset].description)
    return llm.ask(prompt, YesNo, purpose="entity_judge", system=domain.system)


def select_entities(llm: LLM, db: AssetDatabase, domain: Domain, chain: list[str], *,
                    behavior: Behavior | None = None) -> Judged:
    """Entities of the database directly related to the event ``chain[0]``.

    An event that names a person or an animal of a kind no asset is (a deer where the database
    has no animal) has no entity, unasked: the event is not simulatable, said so.
    The assets the event's words name (:func:`named_entities`) are taken whatever the model
    answers, first, as decided by the database; an asset only the model chose is rejected when
    it is of the same category as one the words name (it would play the same part again), and
    must otherwise pass a yes/no judge (:func:`judge_entity`), else it is rejected with the
    judge's answer. The robot's own task objects (``DomainBackend.own_objects``) are never a
    cause's entity.
    """
    domain = domain_view(domain)
    own = domain.own_objects(behavior)
    lacking = db.kinds_lacking(chain[0], robot=domain.robot_names)
    if lacking:  # a deer where the database has no animal: nothing can show it, no model asked
        return Judged(call_id="", unknown={w: f"the event names {'an' if k[0] in 'aeiou' else 'a'} {k} ('{w}') and "
                                           f"the {db.name} asset database has no {k}: nothing can show it"
                                           for k, w in lacking.items()})
    options = [a for a in db.entities() if a not in own]
    prompt = render_prompt("entity_edges", domain, chain=chain, source=chain[0],
                           entities=[(a, db.assets[a].description) for a in options])
    got = llm.ask(prompt, EntitySelection, purpose="entity_edges", system=domain.system)
    out = Judged(call_id=got.call_id)
    for asset, why in named_entities(db, domain, chain[0], own=own).items():
        out.accepted[asset] = why
        out.named[asset] = why
    robot = domain.robot
    # words that name the robot itself ('ego' of 'ego-vehicle'): never guessed to be another asset
    own_words = {w for w in name_words(robot) if db.resolve(w) is None}
    picked: dict[str, str] = {}
    for ch in got.value.entities:
        target, how = _match(ch.name, options, domain.wording.stop_words), None
        if target is not None and normalize(ch.name).replace(" ", "_") != normalize(target).replace(" ", "_"):
            how = ("rule", f"read '{ch.name}' as asset '{target}' (nearly the same name)")
        if target is None and (target := db.resolve(ch.name)) is not None:
            how = ("database", f"resolved '{ch.name}' to asset '{target}' (one of its names in the database)")
        if target is None and own_words.isdisjoint(name_words(ch.name)):
            if (m := db.match(ch.name)) is not None:
                target, how = m.asset, ("rule", m.describe(ch.name))
        if target in own:
            out.rejected[target] = (f"'{target}' is the {robot}'s own task object, not a cause of the "
                                    "task: a cause is shown by the world around it")
            continue
        if target is None:
            out.unknown[ch.name] = _unknown_reason(db, ch.name, robot, own_words)
        elif target not in out.accepted and target not in picked:
            picked[target] = ch.reason or "directly related"
            if how:
                out.matched[target] = how
    extra = [a for a in picked if a not in out.named]
    # an asset the model adds beside one the words name, of the same kind, plays the same part
    # twice ('the front car' bound to a sedan, and a traffic queue added ahead as well)
    kinds = {k: a for a in out.named if (k := db.category_of(a)) in domain.wording.one_part_per_category}
    for a in list(extra):
        named_kind = kinds.get(db.category_of(a) or "")
        if named_kind is not None:
            extra.remove(a)
            out.matched.pop(a, None)
            out.rejected[a] = (f"the event names a {named_kind.replace('_', ' ')} ({db.category_of(a)}); a "
                               f"{a.replace('_', ' ')} the model added would play the same part again")
    verdicts = llm.map(lambda a: judge_entity(llm, db, domain, chain[0], a), extra)
    for asset, v in zip(extra, verdicts, strict=True):
        out.calls[asset] = v.call_id
        if v.value.answer == "yes":
            out.accepted[asset] = picked[asset]
        else:
            out.matched.pop(asset, None)
            out.rejected[asset] = f"the entity judge answered no: a {asset} takes no part in: {chain[0]}"
    return out


def _unknown_reason(db: AssetDatabase, name: str, robot: str, own: set[str]) -> str:
    why = f"'{name}' is not in the {db.name} asset database"
    if not own.isdisjoint(name_words(name)):
        return why + f" (it names the {robot} itself)"
    near = db.closest(name)
    if near is not None:
        why += (f" (closest: '{near.asset}', similarity {near.similarity:.2f}, below "
                f"{MATCH_THRESHOLD:.2f})")
    return why
