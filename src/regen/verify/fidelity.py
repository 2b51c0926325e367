"""Fidelity: does the scenario show what its cause's words name?

The FSM monitor says whether the scenario played out; this says whether what played out is
the cause in the scenario's title. Before a scenario is called verified, its entities, their
behaviors and states are compared with what each cause event's words name:

1. every asset the text names (an id, alias or description phrase, or a state only that asset has:
   :meth:`~regen.assets.database.AssetDatabase.named_assets`) is played by an entity that
   answers to that name (a 'car' may be a police car, never a traffic cone);
2. every state the text names for an entity's property (``named_by`` phrases of the database:
   an ambulance let pass has its siren on) is the state that entity has;
3. a motion the text names ('wrong-way driver': wrong_way) is one some entity can make;
4. some entity other than the robot and its task's own objects shows the cause (a door alone
   does not show a pet let in);
5. where the text names no asset, a state it names ('distracted') is one that some entity of
   the scenario can have (a driver's state needs a vehicle; a green light and pedestrians do not
   show a distracted driver);
6. a person or an animal the words name in words no asset carries ('grandma', 'a puppy':
   :mod:`regen.assets.kinds`) is shown by some entity of that kind (a book and a trash can do
   not show grandma).

A mismatch makes the verdict ``unfaithful`` (not feasible), with what the text names and what
the scenario shows. Where the text names no asset, rules cannot decide: yes/no model questions
(:func:`ask_model`, at grounding: one per entity that may show the cause, with its states) decide
and are recorded as such; without a model the fidelity is ``undecided`` and the verdict stays
what the monitor said. The judge's labeled set and its figures: ``benchmarks/fidelity_judge.py``.

Imports: the shared core, embeddings, assets and llm; no domain.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

from regen.core.base import Answer
from regen.core.verdict import Fidelity, Verdict
from regen.core.words import name_words
from regen.embeddings import optional_encoder
from regen.templates import render

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.scenario import Entity, Scenario
    from regen.core.trace import Trace
    from regen.llm.client import LLM


#: the behavior of an entity whose motion an imported file gives (``regen import``): no motion
#: primitive, so no words can be checked against it
IMPORTED = "storyboard"


def _shown(e: Entity) -> str:
    props = ", ".join(f"{k} = {v}" for k, v in e.properties.items()
                      if k not in ("behavior", "start_location", "target_speed", "location"))
    what = e.behavior or "stationary"
    return f"{e.asset} ({what}{'; ' + props if props else ''})"


def _explained_by_a_behavior(phrase: str, cast: list[Entity]) -> bool:
    """Whether the words of a state phrase are those of an actor's motion primitive ('red light'
    of an actor that runs a red light): the phrase says what that actor does, not a state."""
    words = set(name_words(phrase))
    return any(e.behavior and words <= set(name_words(e.behavior)) for e in cast)


def check_rules(scenario: Scenario, db: AssetDatabase, *, robot: str | Sequence[str] = "",
                own: frozenset[str] = frozenset(), trace: Trace | None = None,
                paraphrases: bool = False) -> Fidelity:
    """What the cause events' words name against what ``scenario`` shows (rules only).
    ``robot``: the domain's words for the robot (they name no asset); ``own``: the assets of
    the robot's own task; ``trace``: the run, whose recorded states count too (a light that
    starts red and turns green shows green); ``paraphrases``: also require the assets named by
    a close paraphrase (the sentence-embedding model). Off in the pipeline: a paraphrase names a
    kind loosely ('someone' is closest to a person, and a child is someone too), so grounding
    selects that asset but the check does not insist on it."""
    encoder = optional_encoder() if paraphrases else None
    cast = [e for e in scenario.entities if not e.is_robot and e.asset not in own
            and e.asset in db.assets]
    shown = [_shown(e) for e in cast]
    causes = scenario.causal_graph[:-1] or scenario.causal_graph
    if not cast:
        word = robot if isinstance(robot, str) else (robot[0] if robot else "")
        return Fidelity(status="unfaithful", reason="the scenario shows no entity of its cause, only the "
                        f"{word or 'robot'} and its task's own objects", named=[], shown=shown)
    rules = _Rules(db, cast, robot=robot, own=own, trace=trace, encoder=encoder)
    for event in causes:
        by_name = rules.assets(event)
        rules.beings(event, by_name)
        rules.motions(event)
        rules.states(event)
    named = rules.named
    if rules.missing or rules.wrong:
        return Fidelity(status="unfaithful", named=named, shown=shown,
                        reason="; ".join(rules.missing + rules.wrong) + f"; the scenario shows {', '.join(shown)}")
    if not any(not n.count(".") for n in named):  # no asset named: rules cannot say who plays it
        return _no_asset_named(scenario, db, causes, cast, named, shown)
    return Fidelity(status="faithful", named=named, shown=shown,
                    reason=f"shows what the cause names: {', '.join(dict.fromkeys(named))}")


@dataclass
class _Rules:
    """The rules of :func:`check_rules` applied to one cause event after the other: what the words
    name (``named``), what the scenario lacks (``missing``) and the states it has wrong (``wrong``)."""

    db: AssetDatabase
    cast: list[Entity]  # the entities that may play a cause
    robot: str | Sequence[str]
    own: frozenset[str]
    trace: Trace | None
    encoder: object | None  # the sentence-embedding model (paraphrases), or None
    named: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    wrong: list[str] = field(default_factory=list)

    def assets(self, event: str) -> list:
        """1. every asset the words name is played by an entity that answers to its name; returns
        those named."""
        db, robot, own = self.db, self.robot, self.own
        by_name = db.named_in(event, exclude=robot, skip=own)  # a state alone names no entity here
        by_name += db.implied_by_words(event, exclude=robot, skip=own | {m.asset for m in by_name})
        if self.encoder is not None:
            by_name += db.paraphrased_in(event, self.encoder, exclude=robot, skip=own)
        for m in by_name:
            self.named.append(m.asset)
            if not any(e.asset == m.asset or db.answers_to(e.asset, m.key) for e in self.cast):
                if m.via == "words":
                    self.missing.append(f"'{event}' implies a {m.asset.replace('_', ' ')} ('{m.key}')")
                    continue
                said = f"'{m.phrase}', a close paraphrase of " if m.phrase else ""
                self.missing.append(f"'{event}' names {said}a {m.key.replace('_', ' ')}")
        return by_name

    def beings(self, event: str, by_name: list) -> None:
        """6. a person or an animal the words name, whatever asset plays them; where an asset of
        that kind is named (``by_name``), rule 1 holds it to that asset."""
        db = self.db
        by_asset = {k for m in by_name for k in db.kinds_of(m.asset)}
        for kind, word in db.beings_in(event, exclude=self.robot).items():
            if kind in by_asset:
                continue
            if any(kind in db.kinds_of(e.asset) for e in self.cast):
                self.named.append(f"a {kind} ('{word}')")
            else:
                self.missing.append(f"'{event}' names {'an' if kind[0] in 'aeiou' else 'a'} {kind} ('{word}'), "
                                    f"and no entity of the scenario is one")

    def motions(self, event: str) -> None:
        """3. a motion the words name is one some entity can make."""
        motions = self.db.named_motions(event, robot=self.robot)
        if motions and not any(set(motions) & set(self.db.assets[e.asset].behaviors) for e in self.cast):
            said = ", ".join(f"'{ph}' ({m})" for m, ph in motions.items())
            self.missing.append(f"'{event}' names a motion, {said}, that nobody in the scenario can make")
            self.named.extend(f"behavior = {m}" for m in motions)
        self.named.extend(f"{e.asset} making {e.behavior}" for e in self.cast if e.behavior in motions)  # rules decide

    def states(self, event: str) -> None:
        """2. every state the words name for an entity's property is the state it has (or has
        during the run)."""
        for e in self.cast:
            for prop in self.db.parameters_of(e.asset):
                if prop == "behavior" and e.behavior == IMPORTED:  # its motion is the imported file's
                    continue
                hits = self.db.named_states(e.asset, prop, event)
                if not hits:
                    continue
                have = e.properties.get(prop) if prop != "behavior" else (e.behavior or e.properties.get(prop))
                if have in hits:  # one of the states the words name (others may be another actor's)
                    self.named.append(f"{e.name}.{prop} = {have}")
                    continue
                track = self.trace.actors.get(e.name) if self.trace is not None else None
                during = set(track.states.get(prop, [])) if track is not None else set()
                hits = {st: ph for st, ph in hits.items() if not _explained_by_a_behavior(ph, self.cast)}
                # 'runs the red light': the red light of the runner, not this one's
                if len(hits) != 1:
                    continue  # nothing left, or words naming several actors' states: no verdict
                ((state, phrase),) = hits.items()
                self.named.append(f"{e.name}.{prop} = {state}")
                if have is not None and state not in during:
                    self.wrong.append(f"'{phrase}' names {prop} = {state}, {e.name} has {prop} = {have}")


def _no_asset_named(scenario: Scenario, db: AssetDatabase, causes: list[str], cast: list[Entity],
                    named: list[str], shown: list[str]) -> Fidelity:
    """Where the words name no asset, rules cannot say who plays it, unless they name a state that
    nothing in the scenario can be in ('a distracted driver' where no entity has a driver): then
    no entity plays it, whoever it was meant to be."""
    holders = {p for e in scenario.entities if e.asset in db.assets for p in db.parameters_of(e.asset)}
    absent = [(prop, st, ph) for event in causes for prop, st, ph in db.named_property_states(event)
              if prop not in holders and not _explained_by_a_behavior(ph, cast)]
    if absent:
        said = ", ".join(f"'{ph}' ({prop} = {st})" for prop, st, ph in absent)
        return Fidelity(status="unfaithful", named=named + [f"{p} = {st}" for p, st, _ in absent], shown=shown,
                        reason=f"the cause names {said}, a state no entity of the scenario can have; "
                               f"the scenario shows {', '.join(shown)}")
    return Fidelity(status="undecided", named=named, shown=shown,
                    reason="the cause names no asset of the database; rules cannot decide")


class _Shows(Answer):
    answer: Literal["yes", "no"]


#: properties that are no state of an entity: where it is, how fast it starts, what part it plays
_NOT_STATES = ("behavior", "start_location", "target_speed", "location", "role")


def _may_show(e: Entity) -> bool:
    """Whether an entity may show a cause: not the robot, nor what a domain's ``role`` property
    marks as the robot's task or its stage (manipulation: the furniture it acts on, the item it
    moves, the table; only its ``context`` entities stand for the world)."""
    return not e.is_robot and e.properties.get("role", "context") == "context"


def _thing(e: Entity) -> str:
    """An entity as the judge is shown it: its asset in words, its motion if it has one, and its
    states ('desk lamp (power = off)')."""
    moves = [e.behavior] if e.behavior and e.behavior not in ("stationary", IMPORTED) else []
    states = [f"{k} = {v}" for k, v in e.properties.items() if k not in _NOT_STATES]
    said = "; ".join(filter(None, [", ".join(moves), ", ".join(states)]))
    return e.asset.replace("_", " ") + (f" ({said})" if said else "")


def ask_model(scenario: Scenario, llm: LLM, *, robot: str, system: str | None = None) -> Fidelity:
    """Where the cause's words name no asset: does some entity of the scene show the cause?

    One yes/no question per entity that may show it (:func:`_may_show`), each shown alone with
    its states: the offline model calls almost any scene shown whole 'shown', but tells one
    thing that the cause is about (a pet for 'something furry scratches to come in') from one it
    is not (a cup; a desk lamp that is off for a painting to be shown off) far better. The scene
    shows the cause when one answer is yes. A scene with no such entity (only the robot and its
    task's own objects) does not, by rule: no model is asked."""
    shown = [_shown(e) for e in scenario.entities if not e.is_robot]
    cause = "; ".join(scenario.causal_graph[:-1] or scenario.causal_graph)
    things = [e for e in scenario.entities if _may_show(e)]
    if not things:
        return Fidelity(status="unfaithful", by="rule", shown=shown,
                        reason=f"the scene shows nothing but the {robot} and its task's own objects, "
                               f"so nothing that could show: {cause}")

    def ask(e: Entity):
        prompt = render("regen.verify", "fidelity", robot=robot, task=scenario.behavior.text, cause=cause,
                        thing=_thing(e))
        return llm.ask(prompt, _Shows, purpose="fidelity", system=system)

    answers = llm.map(ask, things)
    yes = [(e, got) for e, got in zip(things, answers, strict=True) if got.value.answer == "yes"]
    if yes:
        return Fidelity(status="faithful", by="model", call_id=yes[0][1].call_id, shown=shown,
                        reason=f"the model judged that {', '.join(_thing(e) for e, _ in yes)} "
                               f"{'shows' if len(yes) == 1 else 'show'}: {cause}")
    return Fidelity(status="unfaithful", by="model", call_id=answers[-1].call_id, shown=shown,
                    reason=f"the model judged that none of {', '.join(_thing(e) for e in things)} shows: {cause}")


def combine(rules: Fidelity, earlier: Fidelity | None) -> Fidelity:
    """The rules' answer, or where they cannot decide the model's answer from grounding."""
    if rules.status == "undecided" and earlier is not None and earlier.by == "model":
        return earlier
    return rules


def with_fidelity(verdict: Verdict, fidelity: Fidelity) -> Verdict:
    """``verdict`` with its fidelity; a verified scenario that is unfaithful becomes
    ``unfaithful`` (not feasible), saying what the text names and what the scenario shows."""
    if not verdict.feasible or fidelity.status != "unfaithful":
        return verdict.model_copy(update={"fidelity": fidelity})
    status: Literal["unfaithful"] = "unfaithful"
    by = "a model judged" if fidelity.by == "model" else "rules found"
    return verdict.model_copy(update={
        "feasible": False, "status": status, "fidelity": fidelity,
        "reason": f"the FSM played out, but the scenario does not show its cause ({by}): {fidelity.reason}"})


__all__ = ["ask_model", "check_rules", "combine", "with_fidelity"]
