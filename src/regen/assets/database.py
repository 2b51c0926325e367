"""Load and query asset databases.

File format (JSON), mirroring the paper's ``node[...] = [...]`` graph with typed sections:

- ``categories``: category -> asset ids (``node["vehicles"] = ["sedan", ...]``)
- ``assets``: asset id -> kind, description, size [m], CARLA blueprint, ``physics`` (mass [kg],
  max speed [m/s], max acceleration and deceleration [m/s^2], for export), its properties and the
  behaviors it supports, and ``implies``: states that words name for this asset only
  (``"tv": {"implies": {"power": {"on": ["tv show"]}}}``), and ``implied_by``: groups of
  phrases that together name the asset where none of its names occurs (``"spill":
  {"implied_by": [[["knocked over", "tipped over"], ["water", "milk"]]]}``)
- ``properties``: property -> enumerated ``states`` (``node["siren"] = ["on", "off"]``), or
  ``null`` where the database enumerates none and the LLM proposes values (locations), and
  ``named_by``: the phrases that name each state in an event's words (``"on": ["let pass"]``)
- ``behaviors``: motion primitive -> the properties that parameterize it
  (``node["constant speed"] = ["ending location", "starting location", "target speed"]``)
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import networkx as nx
from pydantic import Field, ValidationError, model_validator

from regen.assets.matching import (
    DESCRIPTION_WEIGHT,
    MATCH_THRESHOLD,
    main_phrases,
    phrases_in,
    similarity,
)
from regen.assets.naming import AssetMatch, Naming
from regen.core.base import Model
from regen.core.text import UNSAFE, escaped
from regen.errors import AssetDatabaseError, ConfigError
from regen.promises.files import parse_json, read_text


class Physics(Model):
    """An asset's body as another simulator needs it (the OpenSCENARIO export's mass and
    ``Performance``): a road user's with its rider or driver, a group's the members' together."""

    mass: float = Field(gt=0)  # [kg]
    max_speed: float | None = Field(default=None, gt=0)  # [m/s]
    max_acceleration: float | None = Field(default=None, gt=0)  # [m/s^2]
    max_deceleration: float | None = Field(default=None, gt=0)  # [m/s^2]


class AssetSpec(Model):
    kind: Literal["agent", "object", "sensor"]
    description: str
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)  # length, width, height [m]
    blueprint: str | None = None  # CARLA blueprint id, for export
    physics: Physics | None = None  # mass and performance, for export (None: the exporter's nominal)
    aliases: list[str] = Field(default_factory=list)  # other names a model may use ('pedestrian')
    properties: list[str] = Field(default_factory=list)
    behaviors: list[str] = Field(default_factory=list)
    #: members of a group asset, which moves as one body of ``size`` (a queue of cars): pictures
    #: draw it as that many
    count: int = Field(default=1, ge=1, le=12)
    #: states that words name for this asset only, as property -> state -> phrases ('a tv show'
    #: is a tv that is on; a lamp has no show): merged with the property's own ``named_by``
    implies: dict[str, dict[str, list[str]]] = Field(default_factory=dict)
    #: word groups that together name this asset where none of its names occurs: each entry is a
    #: list of groups, and the asset is named when one phrase of every group occurs ('knocked
    #: over' and 'water' name a spill; 'knocked over' alone does not, nor 'water' alone)
    implied_by: list[list[list[str]]] = Field(default_factory=list)

    @model_validator(mode="after")
    def _word_groups(self) -> AssetSpec:
        for entry in self.implied_by:
            if len(entry) < 2 or not all(g and all(p.strip() for p in g) for g in entry):
                raise ValueError("implied_by: each entry needs two or more groups of non-empty phrases "
                                 "(one group alone is an alias)")
        return self


class PropertySpec(Model):
    description: str
    states: list[str] | None = None  # None: free values, proposed by the model
    #: phrases that name a state in an event's words ("turns red" -> turns_red): where one occurs
    #: in the event an entity takes part in, that state is the property's only choice
    named_by: dict[str, list[str]] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _named_states(self) -> PropertySpec:
        unknown = [s for s in self.named_by if s not in (self.states or [])]
        if unknown:
            raise ValueError(f"named_by names {', '.join(unknown)}, which are not states of this "
                             f"property ({', '.join(self.states or []) or 'free values'})")
        return self


class BehaviorSpec(Model):
    description: str
    parameters: list[str] = Field(default_factory=list)


class AssetDatabase(Naming, Model):
    name: str
    simulator: str
    description: str = ""
    categories: dict[str, list[str]]
    assets: dict[str, AssetSpec]
    properties: dict[str, PropertySpec]
    behaviors: dict[str, BehaviorSpec] = Field(default_factory=dict)

    def cross_check(self, source: str) -> None:
        """Every name that one section uses must be defined in another; report file and key."""
        problems: list[str] = []
        for cat, members in self.categories.items():
            problems += _unknown(f"categories.{cat}", members, self.assets, "asset")
        for aid, spec in self.assets.items():
            problems += _unknown(f"assets.{aid}.properties", spec.properties, self.properties, "property")
            problems += _unknown(f"assets.{aid}.behaviors", spec.behaviors, self.behaviors, "behavior")
            for prop, states in spec.implies.items():
                if prop not in spec.properties or prop not in self.properties:
                    problems.append(f"assets.{aid}.implies: {prop!r} is not a property of {aid}")
                    continue
                problems += _unknown(f"assets.{aid}.implies.{prop}", list(states),
                                     dict.fromkeys(self.properties[prop].states or []), "state")
        for bid, spec in self.behaviors.items():
            problems += _unknown(f"behaviors.{bid}.parameters", spec.parameters, self.properties, "property")
        if "behavior" in self.properties and self.properties["behavior"].states is not None:
            problems += _unknown("properties.behavior.states", self.properties["behavior"].states,
                                 self.behaviors, "behavior")
        if problems:
            raise AssetDatabaseError(f"{source}: " + "; ".join(problems))

    # --- queries used by expansion and grounding ----------------------------------------------

    def entities(self) -> list[str]:
        """All simulatable entities, in category order (the entity candidates of the paper)."""
        seen: dict[str, None] = {}
        for members in self.categories.values():
            for a in members:
                seen.setdefault(a, None)
        for a in self.assets:
            seen.setdefault(a, None)
        return list(seen)

    def resolve(self, name: str) -> str | None:
        """The asset a model-written name means: the id itself, or one of its aliases."""
        key = " ".join(name.lower().replace("_", " ").replace("-", " ").split())
        for aid, spec in self.assets.items():
            if key == aid.replace("_", " ") or key in (a.lower() for a in spec.aliases):
                return aid
        return None

    def match(self, name: str, threshold: float = MATCH_THRESHOLD) -> AssetMatch | None:
        """The asset a model-written name most likely means, when it is no id or alias.

        Deterministic similarity (see :func:`similarity`) against every asset's id, aliases and
        description; the best at or above ``threshold`` wins (ties: the earlier asset). Call
        :meth:`resolve` first: an exact id or alias is not a guess. ``None`` when nothing is close
        enough; :meth:`closest` then tells how close the nearest came.
        """
        best = self.closest(name)
        return best if best is not None and best.similarity >= threshold else None

    def closest(self, name: str) -> AssetMatch | None:
        """The most similar asset to ``name`` whatever the score (None when nothing is alike).
        A name with a prepositional tail is also compared by its main phrase ('cup of coffee'
        -> 'cup')."""
        best: AssetMatch | None = None
        top = 0.0
        names = [name, *(p for p in main_phrases(name) if p != name.lower())]
        for aid, spec in self.assets.items():
            keys = [("id", aid), *(("alias", a) for a in spec.aliases)]
            keys += [("description", d) for d in main_phrases(spec.description)]
            for via, key in keys:
                score = max(similarity(n, key) for n in names)
                score *= DESCRIPTION_WEIGHT if via == "description" else 1.0
                if score > top:  # strictly better: ties keep the earlier asset
                    top, best = score, AssetMatch(asset=aid, similarity=round(score, 2), via=via, key=key)
        return best

    def answers_to(self, asset: str, name: str) -> bool:
        """Whether ``asset`` is a thing ``name`` may mean: its id, an alias or a description
        phrase shares ``name``'s head noun closely enough (:func:`similarity`): a 'car' may be a
        police car or a parked car, an 'emergency vehicle' a fire truck, never a traffic cone."""
        spec = self.assets[asset]
        keys = [asset, *spec.aliases, *main_phrases(spec.description)]
        return any(similarity(name, k) >= MATCH_THRESHOLD for k in keys)

    def category_of(self, asset: str) -> str | None:
        for cat, members in self.categories.items():
            if asset in members:
                return cat
        return None

    def property_candidates(self, asset: str, prop: str) -> list[str] | None:
        """Enumerated values of ``prop`` for ``asset`` (None where the model must propose them)."""
        spec = self.assets[asset]
        if prop == "behavior":
            return list(spec.behaviors)
        states = self.properties[prop].states
        return None if states is None else list(states)

    def named_states(self, asset: str, prop: str, event: str) -> dict[str, str]:
        """Every state of ``prop`` that ``event``'s words name for ``asset``, as {state: phrase}:
        whole words, any case; a phrase inside a longer one found ('red' in 'turns red') does
        not count. Several states: the words name states of several actors ('a tow truck pulls
        over to help a broken-down car')."""
        if prop not in self.parameters_of(asset):
            return {}
        # a motion the asset cannot make is another actor's ('a car waits for a child crossing
        # the road': crossing is the child's); 'broken-down' is 'broken down' (plain)
        able = set(self.assets[asset].behaviors) if prop == "behavior" else None
        named_by = dict(self.properties[prop].named_by)
        for st, phs in self.assets[asset].implies.get(prop, {}).items():
            named_by[st] = [*named_by.get(st, []), *phs]
        states = {st: phs for st, phs in named_by.items() if able is None or st in able}
        out: dict[str, str] = {}
        for _, st, ph in phrases_in(event, {prop: states}):  # longest first
            out.setdefault(st, ph)
        return out

    def named_property_states(self, event: str) -> list[tuple[str, str, str]]:
        """(property, state, phrase) for every state ``event``'s words name, whoever could hold
        it (motions excluded: :meth:`named_motions`); :func:`~regen.assets.matching.phrases_in`."""
        return phrases_in(event, {p: s.named_by for p, s in self.properties.items() if p != "behavior"})

    def named_state(self, asset: str, prop: str, event: str) -> tuple[str, str] | None:
        """The one state of ``prop`` that ``event``'s words name for ``asset`` as
        ``(state, phrase)`` (:meth:`named_states`), or None: none, or several (ambiguous)."""
        named = self.named_states(asset, prop, event)
        return next(iter(named.items())) if len(named) == 1 else None

    def parameters_of(self, asset: str) -> list[str]:
        """Properties of an asset, behaviors' parameters included (each once, in order)."""
        spec = self.assets[asset]
        out: dict[str, None] = {p: None for p in spec.properties}
        for b in spec.behaviors:
            for p in self.behaviors[b].parameters:
                out.setdefault(p, None)
        return list(out)

    def graph(self) -> nx.DiGraph:
        """The database as the paper's directed graph: category -> asset -> property -> state."""
        g = nx.DiGraph()
        for cat, members in self.categories.items():
            g.add_node(cat, type="category")
            for a in members:
                g.add_edge(cat, a)
        for aid, spec in self.assets.items():
            g.add_node(aid, type=spec.kind)
            for p in spec.properties:
                g.add_edge(aid, p)
            for b in spec.behaviors:
                g.add_edge(aid, b)
        for pid, spec in self.properties.items():
            g.add_node(pid, type="property")
            for s in spec.states or []:
                g.add_edge(pid, f"{pid}={s}")
                g.nodes[f"{pid}={s}"]["type"] = "state"
        for bid, spec in self.behaviors.items():
            g.add_node(bid, type="behavior")
            for p in spec.parameters:
                g.add_edge(bid, p)
        return g

    def describe(self) -> str:
        """A compact text form of the database for prompts."""
        lines = []
        for cat, members in self.categories.items():
            lines.append(f"{cat}: " + ", ".join(members))
        return "\n".join(lines)


MAX_DATABASE_BYTES = 20_000_000  # an asset database is a small file; larger ones are not read

# Control characters and lone surrogates (regen.core.text): no asset, category or description
# needs them, and they break terminals, pages and UTF-8 files.
_shown = escaped


def _unknown(where: str, names: list[str], known: dict[str, Any], what: str) -> list[str]:
    """One problem per name in ``names`` (the list at ``where``) that ``known`` does not define."""
    return [f"{where}[{i}]: unknown {what} {n!r}" for i, n in enumerate(names) if n not in known]


def _unsafe_text(raw: Any) -> str | None:
    """Where the first unsafe character sits in parsed JSON ('assets.box.description'), if any.
    Iterative: the parser accepts nesting deeper than a recursive walk could follow."""
    stack: list[tuple[str, Any]] = [("", raw)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, str):
            if UNSAFE.search(value):
                return f"{where or '(top level)'} = '{_shown(value)}'"
        elif isinstance(value, dict):
            for k, v in reversed(list(value.items())):
                here = f"{where}.{k}" if where else k
                if UNSAFE.search(k):
                    return _shown(here)
                stack.append((here, v))
        elif isinstance(value, list):
            stack.extend((f"{where}[{i}]", v) for i, v in reversed(list(enumerate(value))))
    return None


def _parse(text: str, source: str) -> AssetDatabase:
    raw = parse_json(text, source, give="an asset database is one JSON object of categories, assets, properties "
                                         "and behaviors", error=AssetDatabaseError)
    if (where := _unsafe_text(raw)) is not None:
        raise AssetDatabaseError(f"{source}: {where}: contains a control character or lone "
                                 "surrogate; remove it (write an emoji as itself, not as a "
                                 "\\ud83d escape)")
    try:
        db = AssetDatabase.model_validate(raw)
    except ValidationError as exc:
        parts = []
        for err in exc.errors():
            loc = ".".join(str(x) for x in err["loc"]) or "(top level)"
            parts.append(f"{loc}: {err['msg']}")
        raise AssetDatabaseError(f"{source}: " + "; ".join(parts)) from None
    db.cross_check(source)
    return db


@lru_cache(maxsize=16)
def load_packaged_database(package: str, resource: str) -> AssetDatabase:
    """A database file shipped inside a package (a domain's own database), parsed once."""
    try:
        text = resources.files(package).joinpath(resource).read_text("utf-8")
    except (FileNotFoundError, ModuleNotFoundError) as exc:
        raise AssetDatabaseError(f"{package}/{resource}: the asset database file is missing ({exc})") from None
    return _parse(text, f"{package}/{resource}")


def load_database(path: str | Path) -> AssetDatabase:
    """A user's asset database JSON file (a domain's own database or a file: :func:`database_of`)."""
    text = read_text(path, what="asset database", give="give the path of a database .json file",
                     limit=MAX_DATABASE_BYTES)
    return _parse(text, str(path))


def database_of(name_or_file: str | Path) -> AssetDatabase:
    """The asset database of a registered domain, or a user's database JSON file."""
    from regen import domains

    key = str(name_or_file)
    if key in domains.names():
        return domains.make(key).database()
    if not Path(key).exists():
        raise ConfigError(f"{key!r} is neither a domain ({', '.join(domains.names())}) nor an existing "
                          "file: give a domain or the path of an asset database .json file")
    return load_database(key)  # a folder or a bad file: its own message says what to give
