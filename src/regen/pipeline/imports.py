"""``regen import``: a scenario file another tool wrote, run through the main job's own stages.

The domain that reads the file's suffix turns it into a scenario
(its :meth:`~regen.contract.DomainBackend.importer`); it is written into a run folder like a
grounded one and then simulated, verified, drawn and exported by :func:`simulate_stage`, and the
run's summary and report are written as ``regen generate`` writes them. A rerun resumes: a
scenario folder whose verdict is on disk and that was made from the same file is kept.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from regen import domains
from regen.contract import DomainBackend, Importer
from regen.core.graph import CausePath
from regen.core.verdict import Verdict
from regen.errors import ConfigError
from regen.pipeline.stages import ScenarioOutcome, simulate_stage
from regen.pipeline.summary import RunResult, finish
from regen.promises.names import slug
from regen.runfolder import RunFolder, RunSettings
from regen.runfolder.manifest import now


def _suffixes(backend: DomainBackend) -> tuple[str, ...]:
    """The file suffixes the domain imports (none without an importer)."""
    importer = backend.importer()
    return importer.suffixes if importer is not None else ()


def _known_suffixes() -> list[str]:
    """The file suffixes some registered domain imports, sorted."""
    return sorted({s for n in domains.names() for s in _suffixes(domains.make(n))})


def _importer_of(backend: DomainBackend) -> Importer:
    """The domain's importer; ConfigError when it imports no files."""
    importer = backend.importer()
    if importer is None:
        raise ConfigError(f"the {backend.name} domain imports no scenario files")
    return importer


def backend_for(file: Path, domain: str | None = None) -> DomainBackend:
    """The domain that imports ``file``: ``domain``, else the one whose suffixes include its suffix."""
    if domain is not None:
        backend = domains.make(domain)
        if file.suffix.lower() not in _suffixes(backend):
            raise ConfigError(f"the {domain} domain imports {', '.join(_suffixes(backend)) or 'no files'}, "
                              f"not {file.suffix or 'files without a suffix'}")
        return backend
    for name in domains.names():
        backend = domains.make(name)
        if file.suffix.lower() in _suffixes(backend):
            return backend
    raise ConfigError(f"{file.name}: no domain imports {file.suffix or 'files without a suffix'} files; "
                      f"regen import reads {', '.join(_known_suffixes())}")


def import_file(file: str | Path, out: str | Path, *, domain: str | None = None, pictures: bool = True,
                fresh: bool = False, on_event: Callable[[dict[str, Any]], None] | None = None) -> RunResult:
    """Import ``file`` into the run folder ``out`` and simulate and verify it (see the module
    docstring)."""
    file = Path(file)
    if not file.is_file():
        raise ConfigError(f"{file}: {'a folder, not a file' if file.is_dir() else 'no such file'}; give a scenario file ({', '.join(_known_suffixes())})")
    backend = backend_for(file, domain)
    started = time.perf_counter()

    def emit(kind: str, **data: Any) -> None:
        if on_event is not None:
            on_event({"t": round(time.perf_counter() - started, 3), "event": kind, **data})

    emit("stage", stage="import")
    scenario = _importer_of(backend).read(file)
    settings = RunSettings(llm="none", max_scenarios=1, pictures=pictures)
    run = RunFolder(out)
    digest = hashlib.sha256(file.read_bytes()).hexdigest()[:16]  # another file's run is not resumed
    manifest = run.open(scenario.behavior, settings, {"imported": f"{file.name} sha256:{digest}"}, fresh=fresh)
    try:
        name = f"01-{slug(file.stem, fallback='scenario')}"  # a file's stem: slugged, never refused
        manifest.scenarios = [name]
        run.write_manifest(manifest)
        folder = run.scenario(name)
        # as it reads back from path.json (tuples of the behavior's parameters become lists)
        path = CausePath.model_validate_json(CausePath(behavior=scenario.behavior,
                                                       events=scenario.causal_graph).model_dump_json())
        done = folder.verdict() if folder.holds(path) else None
        if done is None:
            folder.reset(grounding=True)
            folder.start(path)
            folder.write_scenario(scenario, backend.config(scenario))
            emit("simulating", name=name)
            res = simulate_stage(backend.name, str(folder.path), pictures)
            done = Verdict.model_validate(res["verdict"])
            outcome = ScenarioOutcome(name, done, timings=res["timings"], path=folder.path)
        else:
            outcome = ScenarioOutcome(name, done, skipped=True, path=folder.path)
        emit("scenario_done", name=name, feasible=done.feasible, status=done.status, reason=done.reason)
        manifest.status = "done"
        manifest.finished = now()
        finish(run, manifest, [outcome], emit)
    finally:
        run.unlock()
    return RunResult(run.path, manifest, None, [outcome])


__all__ = ["backend_for", "import_file"]
