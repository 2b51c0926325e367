"""Entity fidelity on a labeled set of cause texts: ``regen eval --fidelity FILE``.

Each case is run the way a user who insists on a cause runs it: ``regen generate BEHAVIOR
--cause CAUSE --causes 1 -n 1`` with the given model (the main job's own stages, through
:func:`regen.pipeline.generate`), into ``<out>/<case id>/``; a finished case is not run again
(rerunning the command resumes). The scenario grounded for the insisted cause is compared with
the case's labels:

- entity accuracy: share of cases whose scenario has, for every expected entity, an entity of
  one of its acceptable assets;
- key-state accuracy: share of expected key states (``property`` in the acceptable values) that
  the matching entity has (its motion primitive for ``behavior``);
- verified and unfaithful: verified scenarios whose labels do not match (an expected entity or
  state missing): the figure that must be 0;
- the verdicts, ``unfaithful`` ones included (the verifier's own fidelity check);
- verified and caused: verified scenarios whose but-for check (:mod:`regen.verify.causal`) says
  ``caused``, beside how many it could check.

Figures are given per split (``tune``, ``test``): a figure counts only on the half nobody tuned on.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.core.verdict import FEASIBLE_STATUSES
from regen.promises.folders import output_folder
from regen.promises.names import child, safe_name

RESULTS = "fidelity.jsonl"


@dataclass
class CaseResult:
    id: str
    domain: str
    split: str
    status: str  # the verdict of the insisted cause's scenario, or why there is none
    entities_ok: bool
    states_ok: int
    states_total: int
    shown: list[str] = field(default_factory=list)  # 'asset (primitive; prop = value)'
    folder: str = ""
    causal: str | None = None  # the scenario's causal status (regen.verify.causal), if checked

    @property
    def verified(self) -> bool:
        return self.status in FEASIBLE_STATUSES

    @property
    def label_unfaithful(self) -> bool:
        return not self.entities_ok or self.states_ok < self.states_total


#: where scenario.json keeps a motion primitive's parameters (``behavior_params``) -> the
#: database property they bind ('speed_class' is the solved actor's target_speed)
_MOTION_PARAMS = {"speed_class": "target_speed", "location": "start_location"}


def _entity_values(entity: dict[str, Any]) -> dict[str, str]:
    props = {_MOTION_PARAMS[k]: str(v) for k, v in (entity.get("behavior_params") or {}).items()
             if k in _MOTION_PARAMS}
    props.update({k: str(v) for k, v in (entity.get("properties") or {}).items()})
    if entity.get("behavior"):
        props["behavior"] = str(entity["behavior"])
    return props


def score(case: Any, scenario: dict[str, Any] | None, status: str, folder: str = "",
          causal: str | None = None) -> CaseResult:
    """One case's figures from its scenario (as scenario.json holds it) and verdict status."""
    cast = [e for e in (scenario or {}).get("entities", []) if e.get("kind") not in ("robot", "ego")]
    shown = [f"{e['asset']} ({e.get('behavior') or 'stationary'}"
             + "".join(f"; {k} = {v}" for k, v in (e.get("properties") or {}).items()
                       if k not in ("behavior", "start_location", "target_speed", "location")) + ")"
             for e in cast]
    entities_ok, ok, total = True, 0, 0
    for want in case.entities:
        match = [e for e in cast if e["asset"] in want.any_of]
        entities_ok &= bool(match)
        for prop, values in want.states.items():
            total += 1
            ok += any(_entity_values(e).get(prop) in values for e in match)
    return CaseResult(case.id, case.domain, case.split, status, entities_ok, ok, total, shown, folder, causal)


def run_case(case: Any, out: Path, *, llm: str, seed: int = 0) -> CaseResult:
    """Generate the case's insisted cause into ``out/<id>`` (resuming) and score it."""
    from regen.core.behavior import make_behavior
    from regen.errors import RegenError
    from regen.pipeline import generate
    from regen.runfolder import RunSettings

    params = {k: v for k, v in (("ego_template", case.ego_template), ("reward", case.reward)) if v}
    folder = child(out, case.id, what="the case id")  # a plain name, never a path out of ``out``
    try:
        behavior = make_behavior(case.behavior, case.domain, **params)
        settings = RunSettings(llm=llm, depth=1, max_nodes=1, max_scenarios=1, causes=1,
                               forced_causes=[case.cause], seed=seed, workers=1, pictures=False)
        result = generate(behavior, folder, settings=settings)
    except RegenError as exc:
        return CaseResult(case.id, case.domain, case.split, f"error: {exc}", False, 0,
                          sum(len(w.states) for w in case.entities), [], str(folder))
    for o in result.outcomes:  # the insisted cause's scenario (grounded first), if it has one
        scenario_file = Path(o.path) / "scenario.json" if o.path is not None else None
        scenario = (json.loads(scenario_file.read_text(encoding="utf-8")).get("scenario")
                    if scenario_file is not None and scenario_file.exists() else None)
        if scenario is not None and _same(scenario["causal_graph"][0], case.cause):
            causal = o.verdict.causal.status if o.verdict.causal is not None else None
            return score(case, scenario, o.verdict.status, str(o.path), causal)
        if scenario is None and o.path is not None and _same(_started_cause(Path(o.path)), case.cause):
            return score(case, None, o.verdict.status, str(o.path))
    return score(case, None, "no scenario: the insisted cause was not simulatable", str(folder))


def _same(a: str, b: str) -> bool:
    return " ".join(a.lower().split()).strip(" .") == " ".join(b.lower().split()).strip(" .")


def _started_cause(folder: Path) -> str:
    """The cause a scenario folder was started for (its path.json), when grounding wrote no scenario."""
    try:
        return str(json.loads((folder / "path.json").read_text(encoding="utf-8"))["events"][0])
    except (OSError, ValueError, KeyError, IndexError):
        return ""


def _done(results_file: Path, note: Callable[[str], None] | None) -> dict[str, CaseResult]:
    """The cases ``results_file`` already holds. A last line a kill cut off is dropped (said
    through ``note``) and its case runs again; any other broken line is a ConfigError naming the
    file and the line."""
    from pydantic import TypeAdapter, ValidationError

    from regen.errors import ConfigError
    from regen.promises.files import label, resume_json_lines

    give = f"delete the line (its case runs again) or move {results_file} aside"
    rows, dropped = resume_json_lines(results_file, what="results file", give=give)
    if dropped is not None and note is not None:
        note(dropped)
    adapter = TypeAdapter(CaseResult)
    done: dict[str, CaseResult] = {}
    for n, row in rows:
        try:
            r = adapter.validate_python(row)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(map(str, first["loc"])) or "the line"
            raise ConfigError(f"{label(results_file, 'results file')}, line {n}: {where}: {first['msg']}; not a "
                              f"case result this command wrote: {give}") from None
        done[r.id] = r
    return done


def evaluate_fidelity(cases: Sequence[Any], out: Path, *, llm: str = "local",
                      progress: Callable[[str], None] | None = None,
                      note: Callable[[str], None] | None = None) -> list[CaseResult]:
    """Run every case (resuming those already in ``out/fidelity.jsonl``) and return the results.
    ``note``: told what the resume had to repair (a cut-off last line dropped). A case id that
    cannot name a folder of ``out`` (``../x``, ``/abs``, ``a/b``) is refused before any case runs."""
    for case in cases:
        safe_name(case.id, what="the case id")
    output_folder(out, give="a folder for the fidelity runs")
    results_file = out / RESULTS
    done = _done(results_file, note)
    with open(results_file, "a", encoding="utf-8") as fh:
        for i, case in enumerate(cases, start=1):
            if case.id in done:
                continue
            if progress:
                progress(f"[{i}/{len(cases)}] {case.id}: {case.cause}")
            r = run_case(case, out, llm=llm)
            done[case.id] = r
            fh.write(json.dumps(r.__dict__) + "\n")
            fh.flush()
    return [done[c.id] for c in cases if c.id in done]


def table(results: Sequence[CaseResult]) -> list[dict[str, Any]]:
    """One row per (domain, split) and per domain over both splits."""
    rows = []
    keys = sorted({(r.domain, r.split) for r in results}) + sorted({(r.domain, "all") for r in results})
    for domain, split in keys:
        rs = [r for r in results if r.domain == domain and split in ("all", r.split)]
        total = sum(r.states_total for r in rs)
        verified = [r for r in rs if r.verified]
        rows.append({"domain": domain, "split": split, "cases": len(rs),
                     "entity_accuracy": sum(r.entities_ok for r in rs) / len(rs),
                     "state_accuracy": (sum(r.states_ok for r in rs) / total) if total else None,
                     "verified": len(verified),
                     "verified_and_unfaithful": sum(r.label_unfaithful for r in verified),
                     # of the verified: how many the but-for check found caused, and how many it checked
                     "verified_and_caused": sum(r.causal == "caused" for r in verified),
                     "verified_causal_checked": sum(r.causal not in (None, "not_checked") for r in verified),
                     "unfaithful_verdicts": sum(r.status == "unfaithful" for r in rs)})
    return rows


__all__ = ["CaseResult", "evaluate_fidelity", "run_case", "score", "table"]
