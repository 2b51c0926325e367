"""Write ``report.html``: one self-contained, offline page about a run folder.

Everything a model or a user wrote reaches the page only through Jinja2 with autoescaping on
and with control characters and lone surrogates stripped (:func:`clean_text`, the environment's
``finalize``), and pictures and files are relative links into the run folder, so the page needs
no network and can be moved together with its folder.
"""

from __future__ import annotations

import json
import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from importlib import resources
from pathlib import Path
from typing import Any

import jinja2
from markupsafe import Markup

from regen.core.io import atomic_write_text
from regen.core.text import clean
from regen.errors import ConfigError
from regen.report.load import RunView, ScenarioView, call_purposes, load_run
from regen.templates import environment

log = logging.getLogger(__name__)

__all__ = ["CallRef", "QuantityRow", "call_ids", "clean_text", "parameter_rows", "render_report", "world_rows",
           "write_report"]

REPORT_NAME = "report.html"
MAX_CONFIG_CHARS = 20_000  # the config block is for reading, not for copying whole traces


@dataclass
class ConditionRow:
    label: str  # 'actor: state'
    definition: str  # the predicates of the abstract state, e.g. 'behind(a, ego) and ...'
    alone_at: float | None = None  # [s] first time it held on its own (unmet stage only)
    alone_known: bool = False  # the verdict recorded satisfied_alone for it
    cause: bool = False  # a state in which the scenario's cause plays out


@dataclass
class StageRow:
    index: int  # 1-based
    conditions: list[ConditionRow] = field(default_factory=list)
    reached_at: float | None = None  # [s]
    state: str = "unknown"  # reached, unmet, not_checked, unknown (no verdict)


def stage_rows(sv: ScenarioView) -> list[StageRow]:
    """The FSM stages of a scenario joined with the verdict's stage results."""
    results = {r.index: r for r in (sv.verdict.stages if sv.verdict else [])}
    unmet = sv.verdict.first_unmet_stage if sv.verdict else None
    rows: list[StageRow] = []
    if sv.scenario is not None:
        fsm = sv.scenario.fsm
        defs = {(s.actor, s.name): " and ".join(str(p) for p in s.all_of) for s in fsm.states}
        causes = {(s.actor, s.name) for s in fsm.states if s.cause}
        for k, st in enumerate(fsm.stages, start=1):
            rows.append(StageRow(index=k, conditions=[
                ConditionRow(label=f"{c.actor}: {c.state}", definition=defs.get((c.actor, c.state), ""),
                             cause=(c.actor, c.state) in causes)
                for c in st.conditions]))
    else:  # no scenario.json: the verdict alone still says what was checked
        for r in sorted(results.values(), key=lambda r: r.index):
            rows.append(StageRow(index=r.index,
                                 conditions=[ConditionRow(label=c, definition="") for c in r.conditions]))
    for row in rows:
        res = results.get(row.index)
        if sv.verdict is None:
            row.state = "unknown"
        elif res is not None and res.reached_at is not None:
            row.state, row.reached_at = "reached", res.reached_at
        elif unmet is not None and row.index == unmet:
            row.state = "unmet"
        elif unmet is not None and row.index > unmet:
            row.state = "not_checked"
        else:
            row.state = "unmet" if res is not None else "not_checked"
        if row.state == "unmet" and res is not None:
            for c in row.conditions:
                if c.label in res.satisfied_alone:
                    c.alone_known, c.alone_at = True, res.satisfied_alone[c.label]
    return rows


@dataclass
class CallRef:
    """A model call named in a scenario's world (its cache key), for people to read."""

    key: str  # the full cache key (a SHA-256 hex digest)
    purpose: str  # what it asked, from the run's model cache ('model call' when unknown)

    @property
    def short(self) -> str:
        return self.key[:8]


@dataclass
class QuantityRow:
    """One number or setting of a scenario with what it means (the domain's
    :attr:`regen.contract.ReportHints.quantities`)."""

    entity: str  # '' for a world setting
    name: str
    value: Any
    meaning: str = ""
    unit: str = ""
    calls: list[CallRef] = field(default_factory=list)  # the value lists model calls


_CALL_IDS = re.compile(r"[0-9a-f]{64}(?:,[0-9a-f]{64})*")


def call_ids(value: Any) -> list[str]:
    """The model-call cache keys a world value lists (comma-separated SHA-256 digests), or []."""
    return value.split(",") if isinstance(value, str) and _CALL_IDS.fullmatch(value) else []


def _row(entity: str, name: str, value: Any, quantities: Mapping[str, tuple[str, str]]) -> QuantityRow:
    meaning, unit = quantities.get(name, ("", ""))
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    return QuantityRow(entity, name, value, meaning, unit if number else "")


def parameter_rows(sv: ScenarioView, quantities: Mapping[str, tuple[str, str]] | None = None
                   ) -> list[QuantityRow]:
    """The solved parameters in the scenario's order, with meaning and unit."""
    if sv.scenario is None:
        return []
    q = quantities or {}
    return [_row(ent, name, value, q) for ent, params in sv.scenario.parameters.items()
            for name, value in params.items()]


def world_rows(sv: ScenarioView, quantities: Mapping[str, tuple[str, str]] | None = None,
               purposes: Mapping[str, str] | None = None) -> list[QuantityRow]:
    """The scenario's world settings with meaning and unit; a value listing model calls as
    the calls (purpose and key, :func:`call_ids`)."""
    if sv.scenario is None:
        return []
    rows = []
    for name, value in sv.scenario.world.items():
        row = _row("", name, value, quantities or {})
        row.calls = [CallRef(k, (purposes or {}).get(k, "model call")) for k in call_ids(value)]
        rows.append(row)
    return rows


# --- formatting filters -------------------------------------------------------------------------

def clean_text(value: Any) -> Any:
    """``value`` as page text without unsafe characters (the environment's ``finalize``, so it
    applies to every ``{{ }}``). Markup from macros and ``| safe`` stays markup."""
    if hasattr(value, "__html__"):
        return Markup(clean(value.__html__()))
    return clean(value if isinstance(value, str) else str(value))


def fmt_value(value: Any) -> str:
    """Numbers short (3 decimals at most), everything else as text."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value) or math.isinf(value):
            return str(value)
        return f"{value:.3f}".rstrip("0").rstrip(".") if value != int(value) else f"{value:.1f}"
    if value is None or value == "":
        return "—"
    if isinstance(value, (list, tuple)):
        return ", ".join(fmt_value(v) for v in value) if value else "—"
    return str(value)


def fmt_seconds(value: Any) -> str:
    """Seconds with a precision that suits their size."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return "—"
    if value >= 100:
        return f"{value:.0f} s"
    if value >= 1:
        return f"{value:.1f} s"
    return f"{value:.2f} s"


def fmt_percent(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.0f} %"


def fmt_time(value: Any) -> str:
    """An ISO time as 'YYYY-MM-DD HH:MM:SS' (anything else as given)."""
    if not isinstance(value, str):
        return "—"
    try:
        return datetime.fromisoformat(value).strftime("%Y-%m-%d %H:%M:%S")
    except ValueError:
        return value


def fmt_json(value: Any) -> str:
    text = json.dumps(value, indent=2, default=str, ensure_ascii=False)
    if len(text) > MAX_CONFIG_CHARS:
        text = text[:MAX_CONFIG_CHARS] + f"\n[... {len(text) - MAX_CONFIG_CHARS} more characters]"
    return text


def usage_rows(usage: Any) -> tuple[dict[str, Any] | None, list[tuple[str, dict[str, Any]]]]:
    """(total, [(purpose, stats), ...]) from run.json's ``usage`` (regen.llm UsageStats.as_dict)."""
    if not isinstance(usage, dict):
        return None, []
    total = usage.get("total") if isinstance(usage.get("total"), dict) else None
    by = usage.get("by_purpose")
    rows = [(str(k), v) for k, v in by.items() if isinstance(v, dict)] if isinstance(by, dict) else []
    if total is None and not rows and not {"total", "by_purpose"} & usage.keys():
        total = {k: v for k, v in usage.items() if isinstance(v, (int, float))}  # flat counters
    return total or None, rows


def _environment() -> jinja2.Environment:
    # HTML: every model- or user-written string is escaped; clean_text is the one place text is
    # cleaned (every {{ }} passes through it)
    env = environment("regen.report", "templates", html=True, finalize=clean_text)
    env.filters.update(value=fmt_value, seconds=fmt_seconds, percent=fmt_percent,
                       time=fmt_time, pretty_json=fmt_json)
    return env


def _css() -> str:
    return (resources.files("regen.report") / "static" / "report.css").read_text(encoding="utf-8")


def render_report(view: RunView) -> str:
    """The report page for a loaded run folder, as HTML text."""
    usage_total, usage_by = usage_rows(view.run_field("usage"))
    timings = view.run_field("timings")
    settings = view.run_field("settings")
    quantities = dict(view.hints.quantities)
    keys = [k for sv in view.scenarios if sv.scenario is not None
            for v in sv.scenario.world.values() for k in call_ids(v)]
    purposes = call_purposes(view.run_dir, list(dict.fromkeys(keys)))
    page = _environment().get_template("report.html.j2")
    return page.render(
        run=view, summary=view.summary, css=_css(),
        settings=settings if isinstance(settings, dict) else None,
        timings={str(k): v for k, v in timings.items()} if isinstance(timings, dict) else None,
        usage_total=usage_total, usage_by=usage_by,
        stage_rows=stage_rows,
        parameter_rows=lambda sv: parameter_rows(sv, quantities),
        world_rows=lambda sv: world_rows(sv, quantities, purposes),
        generated=datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S"),
    )


def write_report(run_dir: Path, manifest: dict[str, Any] | None = None) -> Path:
    """Write ``run_dir/report.html`` from what is in the run folder; returns its path.

    Missing or unreadable files inside the folder show as such in the page; only a ``run_dir``
    that is not a folder raises (:class:`regen.errors.ConfigError`).
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ConfigError(f"no run folder at {run_dir}: pass the --out folder of 'regen generate'")
    html = render_report(load_run(run_dir, manifest=manifest))
    out = atomic_write_text(run_dir / REPORT_NAME, html)
    log.info("wrote %s", out)
    return out
