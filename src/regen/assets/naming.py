"""What an event's words name in an asset database: assets by id, alias or description phrase,
by a close paraphrase, by a state only they have, by a motion only some make, or by a state
that several share ('a distracted driver': a driver's state, held by every vehicle).

:class:`Naming` is a part of :class:`~regen.assets.database.AssetDatabase`, kept apart so that
the database's format and loading stay readable.

Imports: the shared core and the assets' name matching only.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

from regen.assets.kinds import beings_named, kinds_of
from regen.assets.matching import (
    FUNCTION_WORDS,
    PARAPHRASE_THRESHOLD,
    key_vectors,
    main_phrases,
    plain,
    without_robot,
)
from regen.core.base import Model
from regen.core.words import has_phrase, name_words
from regen.core.words import surface_words as _surface

if TYPE_CHECKING:
    from regen.assets.database import AssetSpec, PropertySpec


class AssetMatch(Model):
    """How a model-written name was matched to an asset."""

    asset: str
    similarity: float  # 0-1, see :func:`similarity`
    via: Literal["id", "alias", "description", "state", "motion", "paraphrase", "words", "kind"]
    key: str  # the id, alias or description phrase that matched
    phrase: str = ""  # for a paraphrase: the words of the text that matched ``key``; for a kind: the kind

    def describe(self, name: str) -> str:
        what = "" if self.via == "id" else f" (by its {self.via} '{self.key}')"
        return f"matched '{name}' to asset '{self.asset}'{what} (similarity {self.similarity:.2f})"


class Naming:
    """The naming queries of an asset database (a mixin of ``AssetDatabase``)."""

    if TYPE_CHECKING:
        assets: dict[str, AssetSpec]
        properties: dict[str, PropertySpec]
        categories: dict[str, list[str]]

        def entities(self) -> list[str]: ...
        def parameters_of(self, asset: str) -> list[str]: ...
        def named_states(self, asset: str, prop: str, event: str) -> dict[str, str]: ...
        def named_state(self, asset: str, prop: str, event: str) -> tuple[str, str] | None: ...
        def named_property_states(self, event: str) -> list[tuple[str, str, str]]: ...

    def kinds_of(self, asset: str) -> frozenset[str]:
        """The kinds of being (:mod:`regen.assets.kinds`: 'person', 'animal') ``asset`` is; a
        member of the database's 'vehicles' category carries a person, its driver or rider."""
        spec = self.assets[asset]
        return kinds_of(asset, spec.aliases, carries_people=asset in self.categories.get("vehicles", ()))

    @staticmethod
    def beings_in(text: str, *, exclude: str | Sequence[str] = ()) -> dict[str, str]:
        """Kind -> word, for the persons and animals ``text`` names as actors
        (:func:`regen.assets.kinds.beings_named`)."""
        return beings_named(text, exclude=exclude)

    def named_in(self, text: str, *, exclude: str | Sequence[str] = "",
                 skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """The assets ``text`` names, in the order it names them: an asset's id, one of its
        aliases or a description phrase of two words or more, as whole words (plural or
        singular, any case). Where names overlap the longest wins ('police car' over 'car'),
        and an id over an alias over a description. The phrases of ``exclude`` (what the domain
        calls its robot: 'ego-vehicle', 'the vehicle') name no asset where they occur, unless a
        place follows ('the vehicle ahead' is another one); assets in ``skip`` are never returned. Each match has ``similarity`` 1.0 and the matched name as ``key``.
        """
        text = without_robot(text, exclude)
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
        blanked = without_robot(text, exclude)
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

    def implied_by_words(self, text: str, *, exclude: str | Sequence[str] = "",
                         skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """Assets that ``text`` names through words that together imply them (an asset's
        ``implied_by``: 'the dog knocked over its water bowl' has a spill), as whole words,
        outside the words of ``exclude`` (the robot's)."""
        words = name_words(without_robot(text, exclude))
        out: list[AssetMatch] = []
        for aid, spec in self.assets.items():
            if aid in skip:
                continue
            for entry in spec.implied_by:
                said = [next((p for p in group if has_phrase(words, name_words(p))), None) for group in entry]
                if all(said):
                    out.append(AssetMatch(asset=aid, similarity=1.0, via="words", key=" + ".join(said)))  # type: ignore[arg-type]
                    break
        return out

    def named_motions(self, text: str, *, robot: str | Sequence[str] = "") -> dict[str, str]:
        """Every motion (a ``behavior`` state) ``text``'s words name for some asset, as
        {motion: phrase} (:meth:`named_states` over the database's assets); a motion whose
        subject is the robot ('the ego-vehicle turns left', ``robot``'s words) is its own."""
        if "behavior" not in self.properties:
            return {}
        blanked = without_robot(text, robot)
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
        (:meth:`implied_by_states`), by words that together imply it (:meth:`implied_by_words`);
        where none of these names one, by a person or animal named in words no asset carries
        (:meth:`implied_by_kind`), else by a motion only some assets make
        (:meth:`implied_by_motion`) or, with an ``encoder``, by a close paraphrase
        (:meth:`paraphrased_in`); where no name does, by a state several share
        (:meth:`implied_by_shared_states`). ``own``: assets never returned (a task's own object)."""
        out: dict[str, str] = {}
        by_name = self.named_in(text, exclude=robot, skip=own)
        for m in by_name:
            what = "its id" if m.via == "id" else f"its {m.via} '{m.key}'"
            out[m.asset] = f"the event names it ({what})"
        for m in self.implied_by_states(text, skip=own):
            out.setdefault(m.asset, f"the event names a state only it has: {m.key}")
        for m in self.implied_by_words(text, exclude=robot, skip=own):
            out.setdefault(m.asset, f"the event's words imply it together: {m.key}")
        if encoder is not None and not out:
            for m in self.paraphrased_in(text, encoder, exclude=robot, skip=own):
                out.setdefault(m.asset, f"the event names it by a close paraphrase: '{m.phrase}' ~ "
                                        f"'{m.key}' (cosine {m.similarity:.2f} >= {PARAPHRASE_THRESHOLD})")
        if not out:  # 'an elderly man', 'a senior citizen': a person, whom no alias names
            for m in self.implied_by_kind(text, robot=robot, skip=own):
                out[m.asset] = (f"the event names a {m.phrase} in words no asset carries ('{m.key}'); the "
                                "first asset of that kind plays it")
        if not out:
            for m in self.implied_by_motion(text, robot=robot, skip=own):
                out[m.asset] = (f"the event names a motion and no actor: {m.key}; the first asset "
                                "of the database that makes it plays it")
        if not by_name:
            for m in self.implied_by_shared_states(text, robot=robot, skip=own, holders=list(out)):
                out.setdefault(m.asset, f"the event names a state several assets share and no actor that "
                                        f"holds it: {m.key}; the first asset of the database that holds it plays it")
        return out

    def implied_by_kind(self, text: str, *, robot: str | Sequence[str] = "",
                        skip: frozenset[str] = frozenset()) -> list[AssetMatch]:
        """For each person or animal ``text`` names in words no asset carries ('an elderly man',
        'a senior citizen'), the first asset of that kind that is no vehicle (a person on foot is
        an adult, not a car's driver)."""
        vehicles = set(self.categories.get("vehicles", ()))
        out = []
        for kind, word in self.beings_in(text, exclude=robot).items():
            able = [a for a in self.entities() if a not in skip and a not in vehicles and kind in self.kinds_of(a)]
            if able:
                out.append(AssetMatch(asset=able[0], similarity=1.0, via="kind", key=word, phrase=kind))
        return out

    def kinds_lacking(self, text: str, *, robot: str | Sequence[str] = "") -> dict[str, str]:
        """Kind -> word, for each person or animal ``text`` names that no asset of the database is
        (a deer on a road whose database has no animal): nothing can show it."""
        return {k: w for k, w in self.beings_in(text, exclude=robot).items()
                if not any(k in self.kinds_of(a) for a in self.entities())}

    def implied_by_shared_states(self, text: str, *, robot: str | Sequence[str] = "",
                                 skip: frozenset[str] = frozenset(),
                                 holders: Sequence[str] = ()) -> list[AssetMatch]:
        """The holder of a state ``text``'s words name that several assets share, where none of
        ``holders`` (the assets already named) holds it: 'a distracted driver fails to move
        despite a green light' names a driver's state, which every vehicle has, and the light
        has none: the first asset, in the database's category order, that holds the property
        plays it (the generic member of its kind: a car). A one-word phrase counts only beside
        a word of the property's description ('distracted' beside 'driver'), so 'a road hazard'
        names no car with its hazard lights on; a phrase inside a motion the words name
        ('swerves into the lane') is that motion's, not a state."""
        blanked = without_robot(text, robot)
        words = set(name_words(blanked))
        motions = [set(name_words(ph)) for ph in self.named_motions(text, robot=robot).values()]
        out: dict[str, AssetMatch] = {}
        for prop, state, phrase in self.named_property_states(blanked):
            owners = [a for a in self.entities() if a not in skip and prop in self.parameters_of(a)]
            if len(owners) < 2 or any(prop in self.parameters_of(h) for h in holders if h in self.assets):
                continue
            said = set(name_words(phrase))
            if any(said <= m for m in motions):
                continue
            if len(phrase.split()) == 1:
                cues = set(name_words(self.properties[prop].description)) - said - FUNCTION_WORDS
                if not cues & words:
                    continue
            out.setdefault(owners[0], AssetMatch(asset=owners[0], similarity=1.0, via="state",
                                                 key=f"{phrase} ({prop} = {state})"))
        return list(out.values())
