"""The main job: behavior -> graph -> paths -> ground -> simulate -> verify -> export.

Everything goes into a run folder (docs/run-folder.md). Each scenario is written atomically when
it finishes, its verdict last; rerunning the same command resumes: finished scenarios are skipped
and model answers come from the run's cache, so nothing already computed is done again.
"""

from __future__ import annotations

import datetime as dt
import json
import logging
import re
import time
import traceback
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import Field

from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.core.graph import CausePath, ScenarioGraph
from regen.core.io import write_json
from regen.core.scenario import Scenario
from regen.core.verdict import Verdict
from regen.errors import RegenError, RunError
from regen.expand.expansion import Limits, expand
from regen.expand.run import load_graph, save_graph
from regen.llm.client import LLM

log = logging.getLogger(__name__)


class RunSettings(Model):
    llm: str = "local"
    depth: int = 1
    max_nodes: int = 8
    max_scenarios: int = 2
    causes: int = 3
    max_entities: int = 2  # entities kept per event
    prior: str | None = None
    candidates: list[str] = Field(default_factory=list)
    seed: int = 0
    workers: int = 1  # processes for simulation
    pictures: bool = True


class RunManifest(Model):
    behavior: Behavior
    settings: RunSettings
    status: str = "running"
    started: str = ""
    finished: str | None = None
    timings: dict[str, float] = Field(default_factory=dict)
    usage: dict[str, Any] = Field(default_factory=dict)
    scenarios: list[str] = Field(default_factory=list)
    message: str = ""


@dataclass
class ScenarioOutcome:
    folder: str
    verdict: Verdict
    skipped: bool = False  # finished in an earlier run
    timings: dict[str, float] = field(default_factory=dict)


@dataclass
class RunResult:
    run_dir: Path
    manifest: RunManifest
    graph: ScenarioGraph
    outcomes: list[ScenarioOutcome]

    @property
    def feasible(self) -> int:
        return sum(o.verdict.feasible for o in self.outcomes)


Event = dict[str, Any]


def _now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def slug(text: str, n: int = 40) -> str:
    s = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")
    return s[:n].rstrip("-") or "scenario"


def select_paths(paths: list[CausePath], k: int) -> list[CausePath]:
    """Up to ``k`` paths: one per root cause first (diversity across causes), then property
    variants of the same causes (same cause, different properties), in graph order."""
    variants = [p.variants() for p in paths]
    firsts = [v[0] for v in variants]
    rest = [p for v in variants for p in v[1:]]
    seen: set[str] = set()
    ordered: list[CausePath] = []
    for p in firsts:
        (rest if p.events[0] in seen else ordered).append(p)
        seen.add(p.events[0])
    return (ordered + rest)[:k]


def folder_names(paths: list[CausePath]) -> list[str]:
    names: list[str] = []
    for i, p in enumerate(paths, start=1):
        names.append(f"{i:02d}-{slug(p.events[0])}")
    return names


def _verdict_for_error(exc: BaseException, status: str) -> Verdict:
    return Verdict(feasible=False, status=status, reason=f"{type(exc).__name__}: {exc}")  # type: ignore[arg-type]


def _read_verdict(folder: Path) -> Verdict | None:
    try:
        return Verdict.model_validate_json((folder / "verdict.json").read_text())
    except (OSError, ValueError):
        return None


def simulate_and_verify(domain: str, scenario_dir: str, pictures: bool = True) -> dict[str, Any]:
    """Simulate, verify, draw and export one grounded scenario folder. Runs in a worker process
    too, so it takes and returns plain data; the verdict is written last."""
    from regen import domains
    from regen.verify import check_fsm

    folder = Path(scenario_dir)
    timings: dict[str, float] = {}
    scenario = Scenario.model_validate(json.loads((folder / "scenario.json").read_text())["scenario"])
    backend = domains.make(domain)
    try:
        t0 = time.perf_counter()
        sim = backend.simulate(scenario, folder)
        timings["simulate"] = time.perf_counter() - t0
        timings.update({k: v for k, v in sim.timings.items() if k != "simulate"})
        write_json(folder / "trace.json", sim.trace)
        verdict = check_fsm(scenario, sim.trace)
        if pictures:
            t0 = time.perf_counter()
            try:
                backend.render(scenario, sim.trace, verdict, folder)
            except Exception as exc:  # a picture is not worth the verdict
                log.warning("drawing %s failed: %s", folder.name, exc)
                (folder / "error.txt").write_text("drawing failed:\n" + traceback.format_exc())
            timings["render"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        backend.export(scenario, folder, trace=sim.trace)
        timings["export"] = time.perf_counter() - t0
    except Exception as exc:
        (folder / "error.txt").write_text(traceback.format_exc())
        status = "simulation_failed"
        verdict = _verdict_for_error(exc, status)
    write_json(folder / "timings.json", timings)
    write_json(folder / "verdict.json", verdict)
    return {"verdict": verdict.model_dump(mode="json"), "timings": timings}


def generate(behavior: Behavior, out: Path, *, settings: RunSettings | None = None, llm: LLM | None = None,
             replay: bool = False, on_event: Callable[[Event], None] | None = None) -> RunResult:
    """Run the whole pipeline into ``out`` (resuming what an earlier run left).

    Args:
        behavior: the robot behavior and its domain.
        out: the run folder.
        settings: limits, model string, seed, workers.
        llm: a model client (default: ``settings.llm`` with the run's cache file).
        replay: forbid model calls; every answer must be in the run's cache.
        on_event: called with progress events (also appended to events.jsonl).
    """
    from regen import domains

    settings = settings or RunSettings()
    out.mkdir(parents=True, exist_ok=True)
    manifest_path = out / "run.json"
    started = time.perf_counter()
    if manifest_path.exists():
        try:
            old = RunManifest.model_validate_json(manifest_path.read_text())
        except ValueError as exc:
            raise RunError(f"{manifest_path} is unreadable ({exc}); use a new --out folder") from None
        if old.behavior != behavior:
            raise RunError(f"{out} holds a run of another behavior ('{old.behavior.text}', "
                           f"{old.behavior.domain}); use another --out folder")
        manifest = old.model_copy(update={"status": "running", "settings": settings, "finished": None})
    else:
        manifest = RunManifest(behavior=behavior, settings=settings, started=_now())
    write_json(manifest_path, manifest)
    events = open(out / "events.jsonl", "a", encoding="utf-8")

    def emit(kind: str, **data: Any) -> None:
        ev = {"t": round(time.perf_counter() - started, 3), "event": kind, **data}
        events.write(json.dumps(ev, default=str) + "\n")
        events.flush()
        if on_event:
            on_event(ev)

    if llm is None:
        llm = LLM(settings.llm, cache=out / "llm-cache.sqlite", replay=replay,
                  on_call=lambda c: emit("llm_call", purpose=c.purpose, cached=c.cached,
                                         tokens=c.input_tokens + c.output_tokens))
    backend = domains.make(behavior.domain)
    outcomes: list[ScenarioOutcome] = []
    graph: ScenarioGraph | None = None
    try:
        # --- expand ---------------------------------------------------------------------------
        emit("stage", stage="expand")
        t0 = time.perf_counter()
        limits = Limits(max_depth=settings.depth, max_nodes=settings.max_nodes, max_causes=settings.causes,
                        max_entities=settings.max_entities)
        graph = expand(behavior, llm, database=backend.database(), limits=limits, prior=settings.prior,
                       candidates=settings.candidates,
                       on_update=lambda g, what: (write_json(out / "graph.json", g),
                                                  emit("graph", step=what, nodes=len(g.nodes))))
        if graph.stop_reason and "interrupted" in graph.stop_reason:
            raise KeyboardInterrupt
        save_graph(graph, out, pictures=settings.pictures)
        manifest.timings["expand"] = time.perf_counter() - t0
        paths = select_paths(graph.paths(), settings.max_scenarios)
        names = folder_names(paths)
        manifest.scenarios = names
        write_json(manifest_path, manifest)
        emit("paths", total=len(paths), names=names)

        # --- ground (model calls, in this process) ----------------------------------------------
        emit("stage", stage="ground")
        t0 = time.perf_counter()
        pending: list[str] = []
        for i, (path, name) in enumerate(zip(paths, names, strict=True)):
            folder = out / "scenarios" / name
            done = _read_verdict(folder)
            if done is not None:
                outcomes.append(ScenarioOutcome(name, done, skipped=True))
                emit("scenario_done", name=name, feasible=done.feasible, status=done.status, skipped=True)
                continue
            folder.mkdir(parents=True, exist_ok=True)
            write_json(folder / "path.json", path)
            if (folder / "scenario.json").exists():
                pending.append(name)
                continue
            emit("grounding", name=name)
            g0 = time.perf_counter()
            try:
                scenario = backend.ground(path, llm, seed=settings.seed + i)
            except KeyboardInterrupt:
                raise
            except Exception as exc:
                (folder / "error.txt").write_text(traceback.format_exc())
                verdict = _verdict_for_error(exc, "grounding_failed")
                write_json(folder / "verdict.json", verdict)
                outcomes.append(ScenarioOutcome(name, verdict))
                emit("scenario_done", name=name, feasible=False, status=verdict.status)
                continue
            config = backend.config(scenario)
            write_json(folder / "scenario.json", {"scenario": scenario.model_dump(mode="json"),
                                                  "config": config})
            write_json(folder / "timings.json", {"ground": time.perf_counter() - g0,
                                                 "solve": scenario.solver.wall_time})
            if scenario.solver.status in ("infeasible", "model_invalid"):
                verdict = Verdict(feasible=False, status="unsatisfiable",
                                  reason="the constraints cannot all hold: " + "; ".join(scenario.solver.conflicts),
                                  conflicts=scenario.solver.conflicts, relaxations=scenario.solver.relaxations)
                write_json(folder / "verdict.json", verdict)
                outcomes.append(ScenarioOutcome(name, verdict))
                emit("scenario_done", name=name, feasible=False, status=verdict.status)
                continue
            pending.append(name)
        manifest.timings["ground"] = manifest.timings.get("ground", 0.0) + time.perf_counter() - t0

        # --- simulate, verify, draw (CPU; optionally in worker processes) -------------------------
        emit("stage", stage="simulate", total=len(pending))
        t0 = time.perf_counter()
        if settings.workers > 1 and len(pending) > 1:
            with ProcessPoolExecutor(max_workers=settings.workers) as pool:
                futs = {name: pool.submit(simulate_and_verify, behavior.domain, str(out / "scenarios" / name),
                                          settings.pictures) for name in pending}
                for name, fut in futs.items():
                    res = fut.result()
                    _collect(outcomes, name, res, emit)
        else:
            for name in pending:
                emit("simulating", name=name)
                res = simulate_and_verify(behavior.domain, str(out / "scenarios" / name), settings.pictures)
                _collect(outcomes, name, res, emit)
        manifest.timings["simulate"] = manifest.timings.get("simulate", 0.0) + time.perf_counter() - t0
        manifest.status = "done"
    except KeyboardInterrupt:
        manifest.status = "interrupted"
        manifest.message = "interrupted; run the same command again to resume"
        raise
    except RegenError as exc:
        manifest.status = "failed"
        manifest.message = str(exc)
        raise
    finally:
        manifest.usage = llm.stats.as_dict()
        manifest.finished = _now()
        order = {n: i for i, n in enumerate(manifest.scenarios)}
        outcomes.sort(key=lambda o: order.get(o.folder, 1 << 30))
        write_json(manifest_path, manifest)
        if graph is not None:
            _finish(out, manifest, outcomes, emit)
        events.close()
    return RunResult(out, manifest, graph, outcomes)


def _collect(outcomes: list[ScenarioOutcome], name: str, res: dict[str, Any], emit) -> None:
    verdict = Verdict.model_validate(res["verdict"])
    outcomes.append(ScenarioOutcome(name, verdict, timings=res["timings"]))
    emit("scenario_done", name=name, feasible=verdict.feasible, status=verdict.status, reason=verdict.reason)


def _finish(out: Path, manifest: RunManifest, outcomes: list[ScenarioOutcome], emit) -> None:
    feasible = sum(o.verdict.feasible for o in outcomes)
    statuses: dict[str, int] = {}
    for o in outcomes:
        statuses[o.verdict.status] = statuses.get(o.verdict.status, 0) + 1
    summary = {"behavior": manifest.behavior.text, "domain": manifest.behavior.domain,
               "status": manifest.status, "scenarios": len(outcomes), "feasible": feasible,
               "success_rate": (feasible / len(outcomes)) if outcomes else 0.0, "statuses": statuses,
               "timings": manifest.timings, "usage": manifest.usage.get("total", {})}
    write_json(out / "summary.json", summary)
    try:
        from regen.report import write_report

        t0 = time.perf_counter()
        write_report(out)
        manifest.timings["report"] = time.perf_counter() - t0
        write_json(out / "run.json", manifest)
    except ImportError:
        pass
    except Exception as exc:  # the report must never cost the run
        log.warning("report failed: %s", exc)
    emit("finished", **{k: summary[k] for k in ("status", "scenarios", "feasible")})


def list_runs(root: Path) -> list[tuple[Path, RunManifest]]:
    """Run folders under ``root`` (or ``root`` itself), newest first."""
    found = [root] if (root / "run.json").exists() else sorted(p.parent for p in root.glob("*/run.json"))
    out = []
    for p in found:
        try:
            out.append((p, RunManifest.model_validate_json((p / "run.json").read_text())))
        except (OSError, ValueError):
            continue
    return sorted(out, key=lambda x: x[1].started, reverse=True)


__all__ = ["RunManifest", "RunResult", "RunSettings", "generate", "list_runs", "load_graph"]
