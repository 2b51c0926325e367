"""Running a what-if: the edited cause chain grounded, simulated and verified with the main job's
own stage function (:func:`regen.pipeline.stages.run_path`) into ``OUT/<original>-whatif-<hash>/``,
then ``whatif.json`` (:mod:`.record`) and ``whatif.html`` (:mod:`.page`) written there; the
original's folder is linked, not copied."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from regen.errors import ConfigError
from regen.whatif.edits import Edit, apply_edits
from regen.whatif.page import WHATIF_HTML, page
from regen.whatif.record import WHATIF_JSON, WhatIf, changed_stages

if TYPE_CHECKING:
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.core.verdict import Verdict
    from regen.llm.client import LLM


def folder_name(original: Path, edits: list[Edit]) -> str:
    key = json.dumps([e.model_dump() for e in edits], sort_keys=True)
    return f"{original.name}-whatif-{hashlib.sha1(key.encode()).hexdigest()[:8]}"


def judge_root(llm: LLM, domain: str, events: list[str]) -> dict[str, Any]:
    """Whether the chain's root cause still plausibly and directly causes the event after it:
    the expansion's own event judge (and its rule against the robot's own mechanics)."""
    from regen.expand.edges import judge_events, ruled_out

    if len(events) < 2:
        return {"by": "none", "plausible": None, "reason": "the chain has no cause event"}
    root, chain = events[0], events[1:]
    judged = judge_events(llm, domain, chain, [root])
    ruled = ruled_out(domain, root, chain[0])
    ok = root in judged.accepted and ruled is None
    reason = ruled or judged.accepted.get(root) or judged.rejected.get(root, "")
    return {"by": f"model ({llm.provider.id})", "plausible": ok, "reason": reason,
            "call_id": judged.calls.get(root), "root": root}


def prepare(scenario_dir: str | Path, edits: list[Edit]) -> tuple[Any, Scenario, Verdict | None, CausePath]:
    """(source folder, its scenario, its verdict, the counterfactual's cause path); ConfigError
    for a folder that is not a scenario's or an edit that does not apply."""
    from regen import domains
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.core.verdict import Verdict
    from regen.runfolder import ScenarioFolder, read_model

    src = ScenarioFolder(Path(scenario_dir).absolute())
    got = read_model(src / src.SCENARIO, Scenario, key="scenario")
    path = read_model(src / src.PATH, CausePath)
    for name, loaded in ((src.SCENARIO, got), (src.PATH, path)):
        if not loaded.ok:  # the file and what is wrong with it, not only the folder
            raise ConfigError(f"{src / name} is {loaded.problem}: {src.path} is not a scenario folder with a "
                              "readable scenario.json and path.json (give one of RUN/scenarios/<name>/)")
    scenario = got.value
    if not edits:
        raise ConfigError("no edit: give --set, --remove, --add or --ask")
    backend = domains.make(scenario.domain)
    robot = (backend.report_hints.robot, *backend.wording.robot_names)
    new_path = apply_edits(scenario, path.value, edits, backend.database(), robot=robot)
    return src, scenario, read_model(src / src.VERDICT, Verdict).value, new_path


def run_whatif(scenario_dir: str | Path, edits: list[Edit], out: str | Path, *, llm: LLM | None = None,
               judge: LLM | None = None, question: str | None = None,
               edits_by: Literal["user", "model"] = "user", pictures: bool = True) -> tuple[Path, WhatIf]:
    """Apply ``edits`` to the scenario in ``scenario_dir``, then ground (rules, or ``llm``),
    simulate and verify the counterfactual into ``out``; (its folder, the record). ``judge``: a
    model asked whether the counterfactual's root cause still causes what follows it, recorded
    beside the simulation's answer (``explained``: the but-for check), never over it."""
    from regen.pipeline.stages import run_path
    from regen.runfolder import ScenarioFolder

    src, scenario, verdict, new_path = prepare(scenario_dir, edits)
    dest = Path(out).absolute() / folder_name(src.path, edits)
    seed = int(scenario.world.get("seed", 0) or 0)
    outcome = run_path(new_path, dest, llm=llm, seed=seed, pictures=pictures)
    after = ScenarioFolder(dest).scenario()
    shown = _shown_states(edits, src.path, dest)
    judged = ({"by": "none", "plausible": None, "reason": "no model judged whether the edited cause still "
               "causes the behavior; only the simulation decided"} if judge is None
              else judge_root(judge, scenario.domain, new_path.events))
    record = _record(src.path, scenario, verdict, outcome.verdict, after, edits, edits_by, question, judged,
                     shown)
    from regen.core.io import atomic_write_text, write_json

    write_json(dest / WHATIF_JSON, record)
    (dest / "original").unlink(missing_ok=True)
    try:  # the original is linked, not copied
        os.symlink(os.path.relpath(src.path, dest), dest / "original")
    except OSError:
        pass
    atomic_write_text(dest / WHATIF_HTML, page(record, src.path, dest, scenario, after))
    return dest, record


def _record(original: Path, scenario: Scenario, verdict: Verdict | None, got: Verdict, after: Scenario | None,
            edits: list[Edit], edits_by: Literal["user", "model"], question: str | None,
            judged: dict[str, Any], shown: list[dict[str, str]]) -> WhatIf:
    """The what-if record: ``explained`` by simulation alone (the counterfactual's FSM played out
    and, checked with the reference robot, its cause caused the behavior); the model judge, when
    asked, is recorded beside it and never decides."""
    from regen.verify.causal import explains

    explained = explains(got.causal, got.feasible)
    reason = got.reason
    if got.feasible and got.causal is not None:
        reason = f"{got.reason}; cause: {got.causal.status}: {got.causal.reason}"
    if judged.get("plausible") is not None and bool(judged["plausible"]) != explained:
        reason += (f" (the model judge disagrees: it found '{judged.get('root', '')}' "
                   f"{'a' if judged['plausible'] else 'no'} cause: {judged['reason']}; the simulation decides)")
    return WhatIf(original=str(original), question=question, edits=edits, edits_by=edits_by,
                  original_status=verdict.status if verdict is not None else "unfinished",
                  original_explained=verdict is not None and explains(verdict.causal, verdict.feasible),
                  status=got.status, explained=explained, judged=judged, reason=reason,
                  causal=got.causal.status if got.causal is not None else None,
                  original_causal=verdict.causal.status if verdict is not None and verdict.causal is not None
                  else None,
                  stages_changed=changed_stages(scenario, after), shown_states=shown)


def _states(folder: Path, entity: str, prop: str) -> str:
    from regen.core.trace import Trace
    from regen.runfolder import read_model

    trace = read_model(folder / "trace.json", Trace).value
    track = trace.actors.get(entity) if trace is not None else None
    if track is None:
        return "not in the scene"
    values = track.states.get(prop)
    return " then ".join(dict.fromkeys(str(v) for v in values)) if values else "not recorded"


def _shown_states(edits: list[Edit], original: Path, dest: Path) -> list[dict[str, str]]:
    out = []
    for e in edits:
        if e.op == "set" and e.entity and e.property and e.property != "behavior":
            out.append({"entity": e.entity, "property": e.property,
                        "before": _states(original, e.entity, e.property),
                        "after": _states(dest, e.entity, e.property)})
    return out


__all__ = ["folder_name", "judge_root", "prepare", "run_whatif"]
