"""``run.json``: how a run was made (:class:`RunSettings`) and where it stands (:class:`RunManifest`)."""

from __future__ import annotations

import datetime as dt
from typing import Any, ClassVar

from pydantic import Field

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.expand.expansion import Limits

_LIMITS = Limits()  # the one place for expansion defaults; the settings below take them from it


class RunSettings(Model):
    """How a run was made. Defaults are those of the main job (``regen generate``)."""

    llm: str = "local"
    depth: int = _LIMITS.max_depth  # event layers behind the behavior
    max_nodes: int = _LIMITS.max_nodes  # accepted cause events
    max_scenarios: int = 3
    causes: int = _LIMITS.max_causes  # candidates per proposal call
    max_entities: int = _LIMITS.max_entities  # entities kept per event
    prior: str | None = None
    candidates: list[str] = Field(default_factory=list)  # causes of the behavior to judge too
    forced_causes: list[str] = Field(default_factory=list)  # causes accepted whatever the judge says
    seed: int = 0
    workers: int = 1  # processes for simulation (does not change results)
    llm_timeout: float | None = None  # [s] per model request; None: REGEN_LLM_TIMEOUT, else 120
    pictures: bool = True  # GIFs and key frames (does not change verdicts)
    #: options of the domain's export (``DomainBackend.export``), e.g. ``{"ego_story": False}``
    #: for driving; they change only the exported files, never a verdict
    export_options: dict[str, bool] = Field(default_factory=dict)

    #: Fields whose change changes what a run produces: a resume must keep them.
    RESULT_FIELDS: ClassVar[tuple[str, ...]] = ("llm", "depth", "max_nodes", "max_scenarios", "causes",
                                      "max_entities", "prior", "candidates", "forced_causes", "seed")

    def limits(self) -> Limits:
        return Limits(max_depth=self.depth, max_nodes=self.max_nodes, max_causes=self.causes,
                      max_entities=self.max_entities)


class RunManifest(Model):
    """``run.json``."""

    behavior: Behavior
    settings: RunSettings
    domain_settings: dict[str, str | None] = Field(default_factory=dict)  # e.g. the resolved ego template
    status: str = "running"  # running, interrupted, failed, done
    started: str = ""
    finished: str | None = None
    timings: dict[str, float] = Field(default_factory=dict)  # stage -> wall seconds, over all invocations
    usage: dict[str, Any] = Field(default_factory=dict)  # model usage over every invocation of the run
    usage_last: dict[str, Any] = Field(default_factory=dict)  # model usage of the last invocation
    scenarios: list[str] = Field(default_factory=list)  # folder names, in run order
    message: str = ""


def merge_usage(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """Sum two usage records (``regen.llm`` ``UsageStats.as_dict``) counter by counter."""

    def add(x: Any, y: Any) -> Any:
        if isinstance(x, dict) and isinstance(y, dict):
            return {k: add(x.get(k), y.get(k)) if k in x and k in y else (x.get(k) if k in x else y[k])
                    for k in {**x, **y}}
        if isinstance(x, (int, float)) and isinstance(y, (int, float)):
            return x + y
        return y if y is not None else x

    return add(a or {}, b or {})


def now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


__all__ = ["RunManifest", "RunSettings", "merge_usage", "now"]
