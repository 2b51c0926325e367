"""Load and query asset databases.

File format (JSON), mirroring the paper's ``node[...] = [...]`` graph with typed sections:

- ``categories``: category -> asset ids (``node["vehicles"] = ["sedan", ...]``)
- ``assets``: asset id -> kind, description, size [m], CARLA blueprint, its properties and the
  behaviors it supports
- ``properties``: property -> enumerated ``states`` (``node["siren"] = ["on", "off"]``), or
  ``null`` where the database enumerates none and the LLM proposes values (locations)
- ``behaviors``: motion primitive -> the properties that parameterize it
  (``node["constant speed"] = ["ending location", "starting location", "target speed"]``)
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import networkx as nx
from pydantic import Field, ValidationError, model_validator

from regen.assets.names import (
    DESCRIPTION_WEIGHT,
    FUNCTION_WORDS,
    MATCH_THRESHOLD,
    PARAPHRASE_THRESHOLD,
    key_vectors,
    main_phrases,
    phrases_in,
    plain,
    similarity,
    without_robot,
)
from regen.core.base import Model
from regen.core.text import UNSAFE, escaped
from regen.core.words import name_words
from regen.core.words import surface_words as _surface
from regen.errors import AssetDatabaseError, ConfigError


class AssetSpec(Model):
    kind: Literal["agent", "object", "sensor"]
    description: str
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)  # length, width, height [m]
    blueprint: str | None = None  # CARLA blueprint id, for export
    aliases: list[str] = Field(default_factory=list)  # other names a model may use ('pedestrian')
    properties: list[str] = Field(default_factory=list)
    behaviors: list[str] = Field(default_factory=list)
    #: members of a group asset, which moves as one body of ``size`` (a queue of cars): pictures
    #: draw it as that many
    count: int = Field(default=1, ge=1, le=12)


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


class AssetMatch(Model):
    """How a model-written name was matched to an asset."""

    asset: str
    similarity: float  # 0-1, see :func:`similarity`
    via: Literal["id", "alias", "description", "state", "motion", "paraphrase"]
    key: str  # the id, alias or description phrase that matched
    phrase: str = ""  # for a paraphrase: the words of the text that matched ``key``

    def describe(self, name: str) -> str:
        what = "" if self.via == "id" else f" (by its {self.via} '{self.key}')"
        return f"matched '{name}' to asset '{self.asset}'{what} (similarity {self.similarity:.2f})"


class AssetDatabase(Model):
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

    def named_in(self, text: str, *, exclude: str | Sequence[str] = "",
                 skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """The assets ``text`` names, in the order it names them: an asset's id, one of its
        aliases or a description phrase of two words or more, as whole words (plural or
        singular, any case). Where names overlap the longest wins ('police car' over 'car'),
        and an id over an alias over a description. The phrases of ``exclude`` (what the domain
        calls its robot: 'ego-vehicle', 'the vehicle') name no asset where they occur, unless a
        place follows ('the vehicle ahead' is another one); assets in ``skip`` are never returned. Each match has ``similarity`` 1.0 and the matched name as ``key``.
        """
        text = without_robot(text, [exclude] if isinstance(exclude, str) else list(exclude))
        words = name_words(text)
        surface = _surface(text)  # as written: a plural key ('pedestrians') beats a singular one
        blocked: set[int] = set()
        found: list[tuple[int, int, int, int, int, str, str, str]] = []  # (-length, exact, rank, start, order, ...)
        for order, (aid, spec) in enumerate(self.assets.items()):
            if aid in skip:
                continue
            keys = [("id", aid), *(("alias", a) for a in spec.aliases)]
            keys += [("description", d) for d in main_phrases(spec.description) if len(d.split()) > 1]
            for rank, (via, key) in enumerate(keys):
                kw = name_words(key)
                for i in range(len(words) - len(kw) + 1):
                    if kw and words[i:i + len(kw)] == kw and blocked.isdisjoint(range(i, i + len(kw))):
                        exact = 0 if surface[i:i + len(kw)] == _surface(key) else 1
                        found.append((-len(kw), exact, min(rank, 2), i, order, aid, via, key))
        taken: set[int] = set()
        out: dict[str, tuple[int, AssetMatch]] = {}
        for neg_len, _, _, start, _, aid, via, key in sorted(found):
            span = set(range(start, start - neg_len))
            if span & taken:
                continue
            taken |= span
            if aid not in out:
                out[aid] = (start, AssetMatch(asset=aid, similarity=1.0, via=via, key=key))  # type: ignore[arg-type]
        return [m for _, m in sorted(out.values(), key=lambda x: x[0])]

    def paraphrased_in(self, text: str, encoder: Any, *, exclude: str | Sequence[str] = "",
                       skip: frozenset[str] = frozenset(),
                       threshold: float = PARAPHRASE_THRESHOLD) -> list[AssetMatch]:
        """The assets ``text`` names by a close paraphrase, where it names none by a name
        (:meth:`named_in`) or by a state only one asset has (:meth:`implied_by_states`): each
        phrase of one to three words that begins and ends with a content word, outside the
        robot's own words, is compared by ``encoder`` (sentence embeddings, ``encode(texts) ->
        unit rows``) with every asset's id and aliases; a phrase names the one asset it is
        closest to when the cosine reaches ``threshold``. A paraphrase speaks only where no
        name does: in 'the police car blocks the road', 'blocks road' (~ 'road block', 0.91)
        says what the police car does; in 'a tree blocks the road' it names the road block."""
        if self.named_in(text, exclude=exclude) or self.implied_by_states(text):
            return []
        names = [exclude] if isinstance(exclude, str) else list(exclude)
        blanked = without_robot(text, names)
        words, base = _surface(blanked), name_words(blanked)
        blocked = {i for i, w in enumerate(base) if w == "itself"}
        grams: list[tuple[int, str]] = []
        for n in (1, 2, 3):
            for i in range(len(words) - n + 1):
                span = range(i, i + n)
                if blocked.isdisjoint(span) and words[i] not in FUNCTION_WORDS \
                        and words[i + n - 1] not in FUNCTION_WORDS:
                    grams.append((i, " ".join(words[i:i + n])))
        keys = [(aid, k) for aid in self.assets if aid not in skip
                for k in (aid.replace("_", " "), *self.assets[aid].aliases)]
        if not grams or not keys:
            return []
        sims = encoder.encode([g for _, g in grams]) @ key_vectors(encoder, tuple(k for _, k in keys)).T
        best: dict[str, tuple[int, float, str, str]] = {}
        for gi, (start, gram) in enumerate(grams):
            ki = int(sims[gi].argmax())
            score, (aid, key) = float(sims[gi, ki]), keys[ki]
            if score >= threshold and score > best.get(aid, (0, 0.0))[1]:
                best[aid] = (start, score, gram, key)
        return [AssetMatch(asset=aid, similarity=round(score, 2), via="paraphrase", key=key, phrase=gram)
                for aid, (_, score, gram, key) in sorted(best.items(), key=lambda x: x[1][0])]

    def implied_by_states(self, text: str, *, skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """Assets that ``text`` names through a state only they have: a phrase of a property's
        ``named_by`` ('turns red') whose property belongs to exactly one asset (a traffic light)."""
        out: list[AssetMatch] = []
        for prop, spec in self.properties.items():
            owners = [a for a in self.assets if prop in self.parameters_of(a) and a not in skip]
            if len(owners) != 1 or not spec.named_by:
                continue
            named = self.named_state(owners[0], prop, text)
            if named is not None and len(named[1].split()) > 1:  # one word ('jammed') is too loose
                out.append(AssetMatch(asset=owners[0], similarity=1.0, via="state",
                                      key=f"{named[1]} ({prop} = {named[0]})"))
        return out

    def named_motions(self, text: str, *, robot: str | Sequence[str] = "") -> dict[str, str]:
        """Every motion (a ``behavior`` state) ``text``'s words name for some asset, as
        {motion: phrase} (:meth:`named_states` over the database's assets); a motion whose
        subject is the robot ('the ego-vehicle turns left', ``robot``'s words) is its own."""
        if "behavior" not in self.properties:
            return {}
        blanked = without_robot(text, [robot] if isinstance(robot, str) else list(robot))
        out: dict[str, str] = {}
        for a in self.assets:
            for st, ph in self.named_states(a, "behavior", blanked).items():
                if not re.search(rf"\bitself\s+{re.escape(plain(ph))}", plain(blanked)):
                    out.setdefault(st, ph)
        return out

    def implied_by_motion(self, text: str, *, robot: str | Sequence[str] = "",
                          skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """The actor of a motion ``text`` names without naming who makes it ('wrong-way driver
        ahead'): the first asset, in the database's category order, that can make that one
        motion (the generic member of its kind: a car). Nothing when the words name several
        motions (several actors) or none (:meth:`named_motions`)."""
        motions = self.named_motions(text, robot=robot)
        if len(motions) != 1:
            return []
        ((motion, phrase),) = motions.items()
        able = [a for a in self.entities() if a not in skip and motion in self.assets[a].behaviors]
        return [AssetMatch(asset=able[0], similarity=1.0, via="motion",
                           key=f"{phrase} (behavior = {motion})")] if able else []

    def named_assets(self, text: str, *, robot: str | Sequence[str] = "",
                     own: frozenset[str] = frozenset(), encoder: Any = None) -> dict[str, str]:
        """Asset -> why, for every asset ``text`` names: by an id, alias or description phrase
        (:meth:`named_in`, the words of ``robot`` excluded), by a state only it has
        (:meth:`implied_by_states`); where none of these names one, by a motion only some assets
        make (:meth:`implied_by_motion`) or, with an ``encoder``, by a close paraphrase
        (:meth:`paraphrased_in`). ``own``: assets never returned (a task's own object)."""
        out: dict[str, str] = {}
        for m in self.named_in(text, exclude=robot, skip=own):
            what = "its id" if m.via == "id" else f"its {m.via} '{m.key}'"
            out[m.asset] = f"the event names it ({what})"
        for m in self.implied_by_states(text, skip=own):
            out.setdefault(m.asset, f"the event names a state only it has: {m.key}")
        if encoder is not None and not out:
            for m in self.paraphrased_in(text, encoder, exclude=robot, skip=own):
                out.setdefault(m.asset, f"the event names it by a close paraphrase: '{m.phrase}' ~ "
                                        f"'{m.key}' (cosine {m.similarity:.2f} >= {PARAPHRASE_THRESHOLD})")
        if not out:
            for m in self.implied_by_motion(text, robot=robot, skip=own):
                out[m.asset] = (f"the event names a motion and no actor: {m.key}; the first asset "
                                "of the database that makes it plays it")
        return out

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
        states = {st: phs for st, phs in self.properties[prop].named_by.items() if able is None or st in able}
        out: dict[str, str] = {}
        for _, st, ph in phrases_in(event, {prop: states}):  # longest first
            out.setdefault(st, ph)
        return out

    def named_property_states(self, event: str) -> list[tuple[str, str, str]]:
        """(property, state, phrase) for every state ``event``'s words name, whoever could hold
        it (motions excluded: :meth:`named_motions`); :func:`~regen.assets.names.phrases_in`."""
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
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise AssetDatabaseError(f"{source}: not valid JSON at line {exc.lineno}, column "
                                 f"{exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise AssetDatabaseError(f"{source}: JSON nested too deeply; an asset database is one "
                                 "JSON object of categories, assets, properties and behaviors") from None
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
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"asset database {str(path)!r} is a folder: give the path of a "
                          "database .json file")
    if not path.is_file():
        raise ConfigError(f"asset database {str(path)!r} is not an existing file: give the path "
                          "of a database .json file")
    try:
        if path.stat().st_size > MAX_DATABASE_BYTES:
            raise ConfigError(f"asset database {str(path)!r} is larger than "
                              f"{MAX_DATABASE_BYTES // 1_000_000} MB: give the path of a database "
                              ".json file")
        data = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"asset database {str(path)!r} cannot be read ({exc.strerror}): check "
                          "its permissions") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"asset database {str(path)!r} is not UTF-8 text (byte "
                          f"0x{data[exc.start]:02x} at offset {exc.start}): save it as UTF-8") from None
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
