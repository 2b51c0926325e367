"""Read run folders defensively into flat records for evaluation.

The layout and the readers are :mod:`regen.runfolder`'s (docs/run-folder.md). Any file may be
missing or from an older format: what cannot be read becomes a note on the record, never a crash.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field, ValidationError

from regen.core.scenario import Scenario
from regen.core.verdict import Verdict
from regen.errors import ConfigError
from regen.report.load import causal_text
from regen.runfolder import RunFolder, read_json

log = logging.getLogger(__name__)


class ScenarioRecord(BaseModel):
    """What evaluation needs from one scenario folder."""

    id: str
    behavior: str  # behavior text
    domain: str | None = None
    text: str = ""  # narrative, else the cause chain joined
    causes: list[str] = Field(default_factory=list)  # event labels, root cause first, behavior excluded
    properties: dict[str, dict[str, str]] = Field(default_factory=dict)  # entity -> property -> value
    feasible: bool | None = None  # None: no verdict
    status: str = "missing"  # the verdict status, or 'missing'
    reason: str = ""
    first_unmet_stage: int | None = None
    #: whether the cause causes the behavior, beside the status: 'caused', 'not_sufficient',
    #: 'confounded: traffic_light1', ...; None: the verdict has no causal part (an older one)
    causal: str | None = None
    causal_reason: str = ""
    notes: list[str] = Field(default_factory=list)  # what could not be read


class RunRecord(BaseModel):
    path: str
    behavior: str
    domain: str | None = None
    scenarios: list[ScenarioRecord] = Field(default_factory=list)
    notes: list[str] = Field(default_factory=list)


def is_run_folder(path: Path) -> bool:
    """A folder with ``run.json`` or a ``scenarios/`` subfolder."""
    run = RunFolder(path)
    return path.is_dir() and (run.is_run() or (run / run.SCENARIOS).is_dir())


def _read_json(path: Path, notes: list[str]) -> Any:
    got = read_json(path)
    if got.problem and got.problem != "missing":
        notes.append(f"{path.name}: {got.problem}")
    return got.value


def _behavior_text(value: Any) -> str | None:
    if isinstance(value, str):
        return value
    if isinstance(value, dict) and isinstance(value.get("text"), str):
        return value["text"]
    return None


def _fill_from_scenario(rec: ScenarioRecord, data: Any) -> None:
    if isinstance(data, dict) and isinstance(data.get("scenario"), dict):
        data = data["scenario"]
    if not isinstance(data, dict):
        rec.notes.append("scenario.json holds no scenario object")
        return
    try:
        sc = Scenario.model_validate(data)
    except ValidationError as exc:
        rec.notes.append(f"scenario.json does not validate ({exc.error_count()} errors); read loosely")
        sc = None
    if sc is not None:
        chain, narrative = sc.causal_graph, sc.narrative
        rec.behavior = sc.behavior.text
        rec.domain = sc.domain
        rec.properties = {e.name: dict(e.properties) for e in sc.entities if e.properties}
    else:
        chain = [str(c) for c in data.get("causal_graph") or [] if isinstance(c, str | int | float)]
        narrative = data.get("narrative") if isinstance(data.get("narrative"), str) else ""
        rec.behavior = _behavior_text(data.get("behavior")) or rec.behavior
        rec.domain = data.get("domain") if isinstance(data.get("domain"), str) else rec.domain
        for e in data.get("entities") or []:
            if isinstance(e, dict) and isinstance(e.get("properties"), dict):
                rec.properties[str(e.get("name", "?"))] = {
                    str(k): str(v) for k, v in e["properties"].items()}
    # causal_graph lists the root cause first and the behavior last
    causes = list(chain)
    if causes and causes[-1].strip().lower() == rec.behavior.strip().lower():
        causes = causes[:-1]
    elif len(causes) > 1:
        causes = causes[:-1]
    rec.causes = causes
    rec.text = narrative.strip() or " -> ".join(chain)


def _fill_from_verdict(rec: ScenarioRecord, data: Any) -> None:
    if not isinstance(data, dict):
        rec.notes.append("verdict.json holds no verdict object")
        return
    try:
        v = Verdict.model_validate(data)
        rec.feasible, rec.status, rec.reason = v.feasible, v.status, v.reason
        rec.first_unmet_stage = v.first_unmet_stage
        rec.causal = causal_text(v.causal)
        rec.causal_reason = v.causal.reason if v.causal is not None else ""
    except ValidationError:
        rec.notes.append("verdict.json does not validate; read loosely")
        if isinstance(data.get("feasible"), bool):
            rec.feasible = data["feasible"]
        rec.status = str(data.get("status") or ("verified" if rec.feasible else "unknown"))
        rec.reason = str(data.get("reason") or "")
        rec.causal, rec.causal_reason = _loose_causal(data.get("causal"))


def _loose_causal(data: Any) -> tuple[str | None, str]:
    """(causal text, reason) of a causal part read field by field (a verdict that does not validate)."""
    if not isinstance(data, dict) or not isinstance(data.get("status"), str) or not data["status"]:
        return None, ""
    names = [str(c) for c in data.get("confounders") or [] if isinstance(c, str | int | float)] \
        if isinstance(data.get("confounders"), list) else []
    reason = data.get("reason") if isinstance(data.get("reason"), str) else ""
    return data["status"] + (f": {', '.join(names)}" if names else ""), reason


def causal_counts(path: str | Path) -> dict[str, int]:
    """Causal status -> number of a run folder's scenarios whose verdict.json has a causal part
    (a verdict without one, or that cannot be read, is not counted)."""
    folder = RunFolder(Path(path))
    counts: dict[str, int] = {}
    for name in folder.scenario_names():
        sf = folder.scenario(name)
        data = read_json(sf / sf.VERDICT).value
        causal = data.get("causal") if isinstance(data, dict) else None
        status = causal.get("status") if isinstance(causal, dict) else None
        if isinstance(status, str) and status:
            counts[status] = counts.get(status, 0) + 1
    return counts


def load_run(path: str | Path) -> RunRecord:
    """Read one run folder. Raises ConfigError only if ``path`` is not a run folder at all."""
    path = Path(path)
    if not is_run_folder(path):
        raise ConfigError(f"{path} is not a run folder (no run.json and no scenarios/ folder)")
    notes: list[str] = []
    folder = RunFolder(path)
    run = _read_json(folder / folder.MANIFEST, notes) or {}
    behavior = _behavior_text(run.get("behavior")) if isinstance(run, dict) else None
    domain = None
    if isinstance(run, dict):
        b = run.get("behavior")
        domain = run.get("domain") or (b.get("domain") if isinstance(b, dict) else None)
    if behavior is None:
        graph = _read_json(folder / folder.GRAPH, notes)
        if isinstance(graph, dict):
            behavior = _behavior_text(graph.get("behavior"))
    rec = RunRecord(path=str(path), behavior=behavior or "", domain=domain, notes=notes)
    for name in folder.scenario_names():
        sf = folder.scenario(name)
        s = ScenarioRecord(id=name, behavior=rec.behavior, domain=rec.domain)
        sdata = _read_json(sf / sf.SCENARIO, s.notes)
        if sdata is not None:
            _fill_from_scenario(s, sdata)
        else:
            s.notes.append("no scenario.json")
        vdata = _read_json(sf / sf.VERDICT, s.notes)
        if vdata is not None:
            _fill_from_verdict(s, vdata)
        rec.scenarios.append(s)
    if not rec.behavior and rec.scenarios:
        rec.behavior = next((s.behavior for s in rec.scenarios if s.behavior), "")
    for s in rec.scenarios:
        s.behavior = s.behavior or rec.behavior or "(unknown behavior)"
    if not rec.behavior:
        rec.behavior = "(unknown behavior)"
    for s in rec.scenarios:
        for n in s.notes:
            log.info("%s/%s: %s", path.name, s.id, n)
    return rec
