"""The batch spec: a YAML file naming many behaviors, each run as ``regen generate`` would run it.

The shape (scripts rely on it)::

    behaviors:
      - text: the ego-vehicle stops abruptly
        domain: driving
        scenarios: 3
        cause: [a child runs across the road]   # optional: any `regen generate` setting
      - text: the robot opens the door
        domain: manipulation
        scenarios: 2

Everything is checked before anything runs: an unknown key, a bad domain, a behavior the
domain refuses or one given twice is refused with the entry's number and text and what to do.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import yaml
from pydantic import Field, ValidationError, field_validator

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.errors import ConfigError
from regen.runfolder import RunSettings

_DEFAULTS = RunSettings()
_LIMITS = _DEFAULTS.limits()


class BehaviorEntry(Model):
    """One entry of ``behaviors:``: the behavior and the ``regen generate`` settings it runs with
    (the same names as the command's options, without dashes)."""

    text: str | None = Field(default=None, description="the behavior text (optional with ego_trajectory)")
    domain: str
    scenarios: int = Field(default=_DEFAULTS.max_scenarios, ge=1)
    cause: list[str] = Field(default_factory=list)
    candidate: list[str] = Field(default_factory=list)
    ego: str | None = None
    reward: str | None = None
    ego_trajectory: str | None = None
    map: str | None = None
    depth: int = Field(default=_LIMITS.max_depth, ge=1)
    max_nodes: int = Field(default=_LIMITS.max_nodes, ge=1)
    causes: int = Field(default=_LIMITS.max_causes, ge=1)
    prior: str | None = None
    seed: int = 0
    llm: str = _DEFAULTS.llm
    llm_timeout: float | None = Field(default=None, gt=0)
    pictures: bool = True
    no_ego_story: bool = False

    @field_validator("cause", "candidate", mode="before")
    @classmethod
    def _one_or_many(cls, v: Any) -> Any:
        return [v] if isinstance(v, str) else v


class BatchSpec(Model):
    """The whole spec file: its behaviors, in run order."""

    behaviors: list[BehaviorEntry] = Field(min_length=1)


class PlannedBehavior(Model):
    """An entry made ready to run: the checked behavior, its run settings, and the lines a
    recorded trajectory was read into (told once when the batch starts)."""

    entry: BehaviorEntry
    behavior: Behavior
    settings: RunSettings
    lines: list[str] = Field(default_factory=list)

    def key(self) -> tuple[str, str, str, tuple[str, ...], tuple[str, ...]]:
        """What makes two entries the same request: domain, text, the domain's parameters and the
        causes given (the same behavior asked for other causes is another request)."""
        params = ",".join(f"{k}={v}" for k, v in sorted(self.behavior.params.items()))
        return (self.behavior.domain, self.behavior.text.lower(), params,
                tuple(sorted(c.lower() for c in self.settings.forced_causes)),
                tuple(sorted(c.lower() for c in self.settings.candidates)))


def _where(i: int, raw: Any) -> str:
    text = raw.get("text") if isinstance(raw, dict) else None
    return f"behaviors entry {i + 1}" + (f" ({text!r})" if text else "")


def read_spec(path: str | Path) -> tuple[BatchSpec, str]:
    """The spec in ``path`` and its sha256; ConfigError naming the entry and what is wrong."""
    p = Path(path)
    try:
        raw_text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"no batch spec at {p}: give a YAML file with a 'behaviors:' list "
                          "(see docs/batch.md)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the batch spec {p}: {exc}") from None
    try:
        raw = yaml.safe_load(raw_text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{p} is not valid YAML: {exc}") from None
    if not isinstance(raw, dict) or "behaviors" not in raw:
        raise ConfigError(f"{p}: a batch spec is a YAML mapping with a 'behaviors:' list (see docs/batch.md)")
    extra = sorted(set(raw) - set(BatchSpec.model_fields))
    if extra:
        raise ConfigError(f"{p}: unknown key(s) {', '.join(extra)}; a spec has only 'behaviors:'")
    entries = raw["behaviors"]
    if not isinstance(entries, list) or not entries:
        raise ConfigError(f"{p}: 'behaviors:' must be a non-empty list of entries with text, domain and scenarios")
    checked = [_entry(i, e, p) for i, e in enumerate(entries)]
    return BatchSpec(behaviors=checked), hashlib.sha256(raw_text.encode()).hexdigest()


def _entry(i: int, raw: Any, path: Path) -> BehaviorEntry:
    where = _where(i, raw)
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: {where} is not a mapping: give text, domain and scenarios")
    unknown = sorted(set(raw) - set(BehaviorEntry.model_fields))
    if unknown:
        takes = ", ".join(BehaviorEntry.model_fields)
        raise ConfigError(f"{path}: {where}: unknown key(s) {', '.join(map(str, unknown))}; an entry takes {takes}")
    try:
        return BehaviorEntry.model_validate(raw)
    except ValidationError as exc:
        why = "; ".join(f"{'.'.join(map(str, e['loc'])) or 'entry'}: {e['msg']}" for e in exc.errors())
        raise ConfigError(f"{path}: {where}: {why}") from None


def plan(spec: BatchSpec, make_behavior: Any, export_options: Any, base: Path | None = None
         ) -> list[PlannedBehavior]:
    """Every entry checked as ``regen generate`` checks its options (``make_behavior`` and
    ``export_options``: :mod:`regen.pipeline.request`), before anything runs; a duplicate
    behavior refused naming both entries. ``base``: the folder relative trajectory paths are
    read from (the spec's)."""
    out: list[PlannedBehavior] = []
    seen: dict[tuple[str, str, str], int] = {}
    for i, e in enumerate(spec.behaviors):
        where = _where(i, e.model_dump())
        trajectory = e.ego_trajectory
        if trajectory is not None and base is not None and not Path(trajectory).is_absolute():
            trajectory = str(base / trajectory)
        try:
            behavior, lines = make_behavior(e.text, e.domain, template=e.ego, reward=e.reward,
                                            trajectory=trajectory, map_name=e.map)
            options = export_options(behavior.domain, e.no_ego_story)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        settings = RunSettings(llm=e.llm, depth=e.depth, max_nodes=e.max_nodes, max_scenarios=e.scenarios,
                               causes=e.causes, prior=e.prior, candidates=e.candidate, forced_causes=e.cause,
                               seed=e.seed, pictures=e.pictures, llm_timeout=e.llm_timeout,
                               export_options=options)
        p = PlannedBehavior(entry=e, behavior=behavior, settings=settings, lines=lines)
        if p.key() in seen:
            raise ConfigError(f"{where} repeats behaviors entry {seen[p.key()] + 1} (same domain, text, "
                              "parameters and causes): give it once, with the larger 'scenarios'")
        seen[p.key()] = i
        out.append(p)
    return out


__all__ = ["BatchSpec", "BehaviorEntry", "PlannedBehavior", "plan", "read_spec"]
