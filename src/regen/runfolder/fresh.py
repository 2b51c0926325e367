"""What ``regen generate --fresh`` may remove: the files a run wrote, and nothing else.

A run writes a fixed set of top-level files (``RunFolder.RUN_FILES``) and one folder per cause
chain under ``scenarios/``. In a scenario folder it writes its own files by name
(``ScenarioFolder.OWN``) and whatever the domain's steps wrote, which ``written.json`` records as
it appears (``files.json`` lists the pictures and exports of a run made before that record was
kept; a name the run wrote into one of its scenario folders counts as the run's in the others).
Anything else in the folder (a user's ``notes.txt``, a ``scenarios/mywork/`` subfolder, a
``scenarios/01-.../my_notes.txt``, another tool's ``run.json``) is not the run's: ``--fresh``
then removes nothing and names what it found (:func:`regen.promises.folders.foreign_error`),
so that the user moves it or chooses another folder. Kept as they are: the model cache, the
lock, ``tests/`` (``regen test``'s results), the counterfactuals ``regen whatif`` and
``regen augment`` wrote into the run (``whatif/``, ``augment/``) and ``regen falsify``'s search
(``falsify/``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from regen.core.graph import CausePath, ScenarioGraph
from regen.errors import RunError
from regen.promises.folders import entries, foreign_error, is_temp_of, listing
from regen.runfolder.manifest import RunManifest
from regen.runfolder.readers import read_model

if TYPE_CHECKING:
    from regen.runfolder.run import RunFolder
    from regen.runfolder.scenario import ScenarioFolder


@dataclass
class FreshPlan:
    """What ``--fresh`` removes: ``files`` (files and the folders the run wrote as a whole),
    then ``folders`` (scenario folders and ``scenarios/``, deepest first), each removed only
    once empty."""

    files: list[Path] = field(default_factory=list)
    folders: list[Path] = field(default_factory=list)


def _made_by_run(sf: ScenarioFolder, listed: set[str]) -> bool:
    """Whether ``scenarios/<name>`` is a scenario folder a run made: listed in run.json, holding
    a cause path (the first file a run writes there), or empty."""
    if sf.name in listed or read_model(sf / sf.PATH, CausePath).ok:
        return True
    try:
        return not any(sf.path.iterdir())
    except OSError:
        return False


def _scenarios(run: RunFolder, base: Path, listed: set[str], plan: FreshPlan,
               foreign: list[str], found: list[str]) -> None:
    """Plan the removal of ``scenarios/``: each scenario folder's own entries; what is not the
    run's goes to ``foreign``."""
    made: list[ScenarioFolder] = []
    for q in entries(base, error=RunError):
        shown = f"{run.SCENARIOS}/{q.name}{'/' if q.is_dir() else ''}"
        found.append(shown)
        sf = run.scenario(q.name) if q.is_dir() and not q.is_symlink() else None
        if sf is not None and _made_by_run(sf, listed):
            made.append(sf)
        else:
            foreign.append(shown)
    known = {n for sf in made for n in sf.written()}  # the run's names, wherever it wrote them
    for sf in made:
        theirs = sf.foreign(known)
        foreign += [f"{run.SCENARIOS}/{sf.name}/{n}" for n in theirs]
        if not theirs:
            plan.files += [p for p in entries(sf.path, error=RunError)]
        plan.folders.append(sf.path)
    plan.folders.append(base)


def fresh_plan(run: RunFolder) -> FreshPlan:
    """What ``--fresh`` removes (see the module docstring). RunError, naming what was found,
    when the folder holds anything a run does not write, or anything at all while it is not
    recognisably a run (neither run.json nor graph.json reads as one)."""
    plan = FreshPlan()
    if not run.path.is_dir():
        return plan
    manifest = read_model(run / run.MANIFEST, RunManifest)
    listed = set(manifest.value.scenarios) if manifest.ok else set()
    foreign: list[str] = []  # what a run does not write
    found: list[str] = []  # everything but the kept entries, as named in a message
    for p in entries(run.path, error=RunError):
        if p.name in run.KEPT:
            continue
        if p.name == run.SCENARIOS and p.is_dir() and not p.is_symlink():
            _scenarios(run, p, listed, plan, foreign, found)
            continue
        found.append(p.name + ("/" if p.is_dir() else ""))
        if (p.name in run.RUN_FILES or is_temp_of(p.name, run.RUN_FILES)) and (p.is_file() or p.is_symlink()):
            plan.files.append(p)
        else:
            foreign.append(found[-1])
    if found and not (manifest.ok or read_model(run / run.GRAPH, ScenarioGraph).ok):
        why = "no run.json" if manifest.problem == "missing" else f"its run.json is {manifest.problem}"
        raise RunError(f"--fresh: {run.path} is not a regen run ({why}); it holds {listing(found)}; "
                       "nothing was removed: move the folder aside or choose another --out")
    if foreign:
        raise foreign_error(run.path, foreign, doing="--fresh", writer="a run", error=RunError)
    return plan


__all__ = ["FreshPlan", "fresh_plan"]
