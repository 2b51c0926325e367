"""The main job: behavior -> graph -> paths -> ground -> simulate -> verify -> export.

The stage functions (:mod:`regen.pipeline.stages`) are the only route from a behavior to a
verdict: ``regen generate``, :func:`generate`, :func:`run_path` (one cause chain, for tests,
benchmarks and library users) and the worker processes all call them. :mod:`.run` holds the
main job (:func:`generate`, and :class:`MainJob` with one method per stage), :mod:`.summary` how
a run ends (``summary.json``, the report, ``run.json`` last) and :mod:`.imports` ``regen import``.
Everything goes into a run folder (:mod:`regen.runfolder`); rerunning the same command resumes:
finished scenarios are skipped and model answers come from the run's cache, so nothing already
computed is done again.

Error policy: a model error that retrying later can fix (replay miss, provider unreachable,
missing key, bad model file) stops the run with its message; the run stays resumable and no
verdict is written for the scenario it hit. So does a disk that takes no more (full, read-only):
one line that says so (exit 2), ``run.json`` "failed", and the resume redoes what is missing,
pictures included. A cause chain that cannot be grounded, an unsatisfiable placement, an
invalid FSM or a simulator failure is that scenario's verdict.
"""

from regen.pipeline.run import MainJob, folder_names, generate, select_paths
from regen.pipeline.stages import (
    ScenarioOutcome,
    ground_stage,
    needs_drawing,
    redraw_stage,
    run_path,
    simulate_stage,
)
from regen.pipeline.summary import Emit, Event, RunResult, finish, summarize
from regen.runfolder import RunManifest, RunSettings

__all__ = ["Emit", "Event", "MainJob", "RunManifest", "RunResult", "RunSettings", "ScenarioOutcome", "finish", "folder_names",
           "generate", "ground_stage", "needs_drawing", "redraw_stage", "run_path", "select_paths",
           "simulate_stage", "summarize"]
