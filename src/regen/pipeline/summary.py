"""The end of a run: what :func:`regen.pipeline.generate` returns (:class:`RunResult`), the
numbers of ``summary.json`` (:func:`summarize`), and :func:`finish`, which writes the summary and
the report before ``run.json``, so that 'done' is only said when all is on disk. ``regen
generate`` and ``regen import`` end with it."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from regen.core.graph import ScenarioGraph
from regen.core.io import cannot_write, write_json
from regen.pipeline.stages import ScenarioOutcome
from regen.runfolder import RunFolder, RunManifest

log = logging.getLogger(__name__)

Event = dict[str, Any]
Emit = Callable[..., None]


@dataclass
class RunResult:
    run_dir: Path
    manifest: RunManifest
    graph: ScenarioGraph | None
    outcomes: list[ScenarioOutcome]

    @property
    def feasible(self) -> int:
        return sum(o.verdict.feasible for o in self.outcomes)


def summarize(manifest: RunManifest, outcomes: list[ScenarioOutcome]) -> dict[str, Any]:
    feasible = sum(o.verdict.feasible for o in outcomes)
    statuses: dict[str, int] = {}
    for o in outcomes:
        statuses[o.verdict.status] = statuses.get(o.verdict.status, 0) + 1
    return {"behavior": manifest.behavior.text, "domain": manifest.behavior.domain,
            "status": manifest.status, "scenarios": len(outcomes), "feasible": feasible,
            "success_rate": (feasible / len(outcomes)) if outcomes else 0.0, "statuses": statuses,
            "relaxed": sum(bool(o.verdict.relaxations) for o in outcomes),
            "with_fallbacks": sum(bool(o.verdict.fallbacks) for o in outcomes),
            "cause_not_shown": statuses.get("cause_not_shown", 0),
            "unfaithful": statuses.get("unfaithful", 0),
            "verified_fsm_source": _fsm_sources(outcomes),
            "timings": manifest.timings, "usage": manifest.usage.get("total", {})}


def _fsm_sources(outcomes: list[ScenarioOutcome]) -> dict[str, int]:
    """Who wrote the FSM of each feasible scenario: {'model': n, 'rules': n, 'model+rules': n}."""
    out: dict[str, int] = {}
    for o in outcomes:
        scenario = o.scenario() if o.verdict.feasible else None
        if scenario is not None:
            out[scenario.fsm_source] = out.get(scenario.fsm_source, 0) + 1
    return out


def finish(run: RunFolder, manifest: RunManifest, outcomes: list[ScenarioOutcome], emit: Emit) -> None:
    """Summary and report first, the manifest last: 'done' is only said when all is on disk."""
    summary = summarize(manifest, outcomes)
    write_json(run / run.SUMMARY, summary)
    from regen.report import write_report

    t0 = time.perf_counter()
    try:
        write_report(run.path, manifest=manifest.model_dump(mode="json"))
    except Exception as exc:  # the report must never cost the run; say so where users look
        if cannot_write(exc, run.path):  # but a full disk stops the run (resumed later)
            raise
        log.warning("report failed: %s", exc, exc_info=True)
        manifest.message = (manifest.message + "; " if manifest.message else "") + f"report failed: {exc}"
    manifest.timings["report"] = time.perf_counter() - t0
    run.write_manifest(manifest)
    emit("finished", **{k: summary[k] for k in ("status", "scenarios", "feasible")})


__all__ = ["Emit", "Event", "RunResult", "finish", "summarize"]
