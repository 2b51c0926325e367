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
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import networkx as nx
from pydantic import Field, ValidationError

from regen.core.base import Model
from regen.core.text import UNSAFE, escaped
from regen.errors import AssetDatabaseError, ConfigError


class AssetSpec(Model):
    kind: Literal["agent", "object", "sensor"]
    description: str
    size: tuple[float, float, float] = (1.0, 1.0, 1.0)  # length, width, height [m]
    blueprint: str | None = None  # CARLA blueprint id, for export
    aliases: list[str] = Field(default_factory=list)  # other names a model may use ('pedestrian')
    properties: list[str] = Field(default_factory=list)
    behaviors: list[str] = Field(default_factory=list)


class PropertySpec(Model):
    description: str
    states: list[str] | None = None  # None: free values, proposed by the model


class BehaviorSpec(Model):
    description: str
    parameters: list[str] = Field(default_factory=list)


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
            for i, a in enumerate(members):
                if a not in self.assets:
                    problems.append(f"categories.{cat}[{i}]: unknown asset {a!r}")
        for aid, spec in self.assets.items():
            for i, p in enumerate(spec.properties):
                if p not in self.properties:
                    problems.append(f"assets.{aid}.properties[{i}]: unknown property {p!r}")
            for i, b in enumerate(spec.behaviors):
                if b not in self.behaviors:
                    problems.append(f"assets.{aid}.behaviors[{i}]: unknown behavior {b!r}")
        for bid, spec in self.behaviors.items():
            for i, p in enumerate(spec.parameters):
                if p not in self.properties:
                    problems.append(f"behaviors.{bid}.parameters[{i}]: unknown property {p!r}")
        if "behavior" in self.properties and self.properties["behavior"].states is not None:
            for i, b in enumerate(self.properties["behavior"].states):
                if b not in self.behaviors:
                    problems.append(f"properties.behavior.states[{i}]: unknown behavior {b!r}")
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
    """A user's asset database JSON file (a domain's own database: ``regen.domains.database``)."""
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
