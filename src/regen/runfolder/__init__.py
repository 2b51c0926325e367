"""The run folder: one package that lays it out, writes it, reads it and decides how to resume it.

The pipeline, the report, evaluation and the CLI all go through this package (layout and
guarantees: docs/run-folder.md). Writes are atomic (temporary file + rename); a scenario is
finished when its ``verdict.json`` exists, which is written last; ``run.json`` says ``done``
only after everything else of the run is on disk. A folder is used by one process at a time
(a lock file), and a rerun resumes only with the settings that made the run: a result-changing
difference stops with a message, unless the user asks for a fresh start.

Readers never raise for a missing or broken file: they return a :class:`Loaded` with the
problem, so a half-finished or hand-edited run can still be shown (:mod:`.readers`).
``run.json`` is :mod:`.manifest`; what ``--fresh`` may remove is :mod:`.fresh`.
"""

from regen.runfolder.manifest import RunManifest, RunSettings, merge_usage, now
from regen.runfolder.readers import (
    MAX_JSON_BYTES,
    MAX_TEXT_CHARS,
    Loaded,
    read_json,
    read_model,
    read_text,
)
from regen.runfolder.run import (
    RunFolder,
    behavior_test_name,
    list_runs,
    read_falsify,
    read_graph,
    read_summary,
    read_tests,
)
from regen.runfolder.scenario import ScenarioFolder

__all__ = ["MAX_JSON_BYTES", "MAX_TEXT_CHARS", "Loaded", "RunFolder", "RunManifest", "RunSettings",
           "ScenarioFolder", "behavior_test_name", "list_runs", "merge_usage", "now",
           "read_falsify", "read_graph", "read_json", "read_model", "read_summary", "read_tests", "read_text"]
