"""Labeled cause texts for entity fidelity (``regen eval --fidelity``).

One JSON object per line: the behavior (its text, domain and ego template or reward), the cause
text a user insists on, the entities the cause names (each as the assets that may play it, with
the key states the text implies: ``{"siren": ["on"]}``; ``behavior`` is the motion primitive)
and a fixed ``split``: ``tune`` (may guide prompt work) or ``test`` (never looked at while
tuning). Each domain ships its set (:attr:`regen.contract.DomainBackend.fidelity_set`, named by
the domain: ``driving`` and ``manipulation``), written before any tuning on them, terse titles among full sentences, every ego behavior and every manipulation task. They
name some assets the databases do not have yet (a tow truck, a road worker, a spill, a
visitor): a cause nobody can play counts as a miss until the database can play it.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Literal

from pydantic import Field, ValidationError

from regen import domains
from regen.core.base import Model
from regen.errors import ConfigError
from regen.promises.files import json_lines, label, text_lines


def _give() -> str:
    return f"give a JSON-lines file (one case object per line) or one of: {', '.join(packaged_sets())}"


class ExpectedEntity(Model):
    any_of: list[str] = Field(min_length=1)  # asset ids that may play the cause
    states: dict[str, list[str]] = Field(default_factory=dict)  # property -> acceptable values


class FidelityCase(Model):
    id: str = Field(min_length=1)
    domain: str
    behavior: str
    ego_template: str | None = None
    reward: str | None = None
    cause: str = Field(min_length=1)
    entities: list[ExpectedEntity] = Field(min_length=1)
    split: Literal["tune", "test"]


def packaged_sets() -> list[str]:
    """The names of the bundled labeled sets: the registered domains that ship one."""
    return [name for name in domains.names() if domains.backend_class(name).fidelity_set is not None]


def load_cases(source: str | Path) -> list[FidelityCase]:
    """The cases of a JSON-lines file, or of a bundled set by name ('driving', 'manipulation')."""
    give = _give()
    if isinstance(source, str) and source in packaged_sets():
        package, resource = domains.backend_class(source).fidelity_set or ("", "")
        text = resources.files(package).joinpath(resource).read_text(encoding="utf-8")
        where = f"bundled set {source!r}"
        rows = text_lines(text, where, give=give)
    else:
        rows = json_lines(source, what="labeled set", give=give)
        where = label(source, "labeled set")
    cases: list[FidelityCase] = []
    seen: set[str] = set()
    for n, value in rows:
        try:
            case = FidelityCase.model_validate(value)
        except ValidationError as exc:
            first = exc.errors()[0]
            raise ConfigError(f"{where}, line {n}: {'.'.join(map(str, first['loc'])) or 'the line'}: "
                              f"{first['msg']}") from None
        if case.id in seen:
            raise ConfigError(f"{where}, line {n}: the id {case.id!r} repeats")
        seen.add(case.id)
        cases.append(case)
    if not cases:
        raise ConfigError(f"{where} holds no cases: {give}")
    return cases


__all__ = ["ExpectedEntity", "FidelityCase", "load_cases", "packaged_sets"]
