"""From run folders to samples: every scenario of a run, every what-if of it and every test
variant of it (``regen test``'s cases) is a candidate; the candidates whose verdict is
``verified`` and whose cause was shown to cause the behavior (``verdict.causal.status ==
'caused'``) and whose label the trace confirms become samples, the others are left out with a
reason. A sample is three frames ending at the decision moment (:data:`FRAME_OFFSETS`), each
drawn as a bird's-eye picture and, where the camera renderer is installed, a forward camera
picture, with every entity's pose, size and states per frame, the label and the QA layers."""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.core.verdict import Verdict
from regen.dataset.labels import LABELS, Label, LeftOut, ego_name, label
from regen.dataset.motion import headings, speeds, step_at
from regen.dataset.qa import QA, SENSOR_STATES, cause_actors, layers
from regen.errors import RunError
from regen.runfolder import RunFolder, ScenarioFolder, read_json, read_model

log = logging.getLogger(__name__)

FRAME_OFFSETS = (-1.0, -0.5, 0.0)  # [s] frame times relative to the decision moment
CAMERA_SIZE = (640, 360)  # [px] forward camera pictures
DOMAIN = "driving"
NOT_A_RUN = ("{path} is not a run folder (no run.json): give the --out folder of 'regen generate' "
             "(or a run folder of 'regen batch'); 'regen runs list {path}' lists the runs under a folder")
INSTRUCTION = ("You drive the ego vehicle. The pictures are the last {n} frames, 0.5 s apart, the last one "
               "now. What should the ego do next? Answer with one of: " + ", ".join(LABELS) + ".")


@dataclass
class Candidate:
    """One scenario that may give a sample: a run's scenario, a what-if of it, or a test variant."""

    sample_id: str
    pair_id: str  # shared by a scenario and its what-ifs and variants
    source: str  # 'scenario', 'whatif', 'variant'
    run: str  # the run folder's name
    scenario_name: str  # the scenario folder's name in the run
    folder: Path | None  # where its files are (None: a variant simulated here)
    scenario: Scenario | None = None
    trace: Trace | None = None
    verdict: Verdict | None = None
    causal: str | None = None  # the causal status that counts (a variant: its original's)
    variant: int = 0
    edits: str = ""
    whatifs: list[dict[str, Any]] = field(default_factory=list)  # for the counterfactual layer
    problem: str = ""  # why it could not be read (left out)


@dataclass
class Sample:
    row: dict[str, Any]
    qa: list[QA]
    images: dict[str, Any]  # relative path -> PIL image


@dataclass(frozen=True)
class Skipped:
    sample_id: str
    source: str
    reason: str
    detail: str


def run_folder(path: str | Path, domain: str = DOMAIN) -> RunFolder:
    """A readable run folder of ``domain``; RunError (exit 2) saying what to pass otherwise."""
    folder = RunFolder(Path(path))
    if not folder.path.is_dir() or not folder.is_run():
        raise RunError(NOT_A_RUN.format(path=path))
    m = folder.read_manifest()
    if m.behavior.domain != domain and domain == DOMAIN:
        raise RunError(f"{path} is a {m.behavior.domain} run: its episodes are written with --format lerobot "
                       "(the parquet and llava formats hold driving samples)")
    if m.behavior.domain != domain:
        raise RunError(f"{path} is a {m.behavior.domain} run; --format lerobot writes {domain} episodes only "
                       "(give the driving runs without --format lerobot)")
    return folder


def _read(folder: Path) -> tuple[Scenario | None, Trace | None, Verdict | None]:
    sf = ScenarioFolder(folder)
    return sf.scenario(), read_model(folder / ScenarioFolder.TRACE, Trace).value, sf.verdict()


def _whatifs(run: RunFolder) -> dict[str, list[Path]]:
    """What-if folders of the run by the scenario folder name they are the counterfactual of."""
    from regen.whatif.record import WHATIF_JSON

    base = run / RunFolder.WHATIF
    out: dict[str, list[Path]] = {}
    if not base.is_dir():
        return out
    scenarios = (run / RunFolder.SCENARIOS).resolve()
    for d in sorted(p for p in base.iterdir() if (p / WHATIF_JSON).is_file()):
        raw = read_json(d / WHATIF_JSON)
        original = Path(str(raw.value.get("original", ""))) if raw.ok and isinstance(raw.value, dict) else None
        if original is not None and original.resolve().parent == scenarios:
            out.setdefault(original.name, []).append(d)
    return out


def _whatif_info(d: Path) -> dict[str, Any]:
    from regen.whatif.record import WHATIF_JSON, WhatIf

    rec = read_model(d / WHATIF_JSON, WhatIf).value
    scenario, trace, verdict = _read(d)
    return {"record": rec, "trace": trace, "ego": ego_name(scenario) if scenario else "ego", "folder": d,
            "causal": verdict.causal if verdict is not None else None}


def _cases(run: RunFolder) -> dict[str, list[Any]]:
    """Test cases of the run with a variant other than the grounded one, by scenario folder."""
    from regen.harness.cases import CaseResult

    out: dict[str, list[Any]] = {}
    tests = run / RunFolder.TESTS
    if not tests.is_dir():
        return out
    for f in sorted(tests.glob(f"*/{RunFolder.TEST_CASES}/*.json")):
        raw = read_json(f)
        if not (raw.ok and isinstance(raw.value, dict) and isinstance(raw.value.get("case"), dict)):
            continue
        try:
            case = CaseResult.model_validate(raw.value["case"])
        except ValueError:
            continue
        if case.variant > 0:
            out.setdefault(case.scenario, []).append(case)
    return out


def candidates(path: str | Path, *, variants: bool = True) -> Iterator[Candidate]:
    """Every candidate of a run folder: its scenarios, then each one's what-ifs and variants."""
    run = run_folder(path)
    name = run.path.resolve().name
    whatifs = _whatifs(run)
    cases = _cases(run) if variants else {}
    for sname in run.scenario_names():
        folder = run.scenario(sname).path
        scenario, trace, verdict = _read(folder)
        base = scenario.id if scenario is not None else f"{name}-{sname}"
        infos = [_whatif_info(d) for d in whatifs.get(sname, [])]
        yield Candidate(sample_id=base, pair_id=base, source="scenario", run=name, scenario_name=sname,
                        folder=folder, scenario=scenario, trace=trace, verdict=verdict,
                        causal=verdict.causal.status if verdict and verdict.causal else None,
                        whatifs=[i for i in infos if i["record"] is not None])
        for info in infos:
            d = info["folder"]
            ws, wt, wv = _read(d)
            rec = info["record"]
            yield Candidate(sample_id=f"{base}-{d.name.rpartition('-whatif-')[2] or d.name}-whatif", pair_id=base,
                            source="whatif", run=name, scenario_name=sname, folder=d, scenario=ws, trace=wt,
                            verdict=wv, causal=wv.causal.status if wv and wv.causal else None,
                            edits="; ".join(e.describe() for e in rec.edits) if rec else "",
                            problem="" if rec else "whatif.json unreadable")
        seen: set[str] = set()
        for case in sorted(cases.get(sname, []), key=lambda c: (c.variant, json.dumps(c.parameters, sort_keys=True))):
            key = json.dumps(case.parameters, sort_keys=True)
            if key in seen:  # the same variant tested with several policies
                continue
            seen.add(key)
            yield _variant(case, base, name, sname, scenario)


def _variant(case: Any, base: str, run: str, sname: str, scenario: Scenario | None) -> Candidate:
    c = Candidate(sample_id=f"{base}-v{case.variant}", pair_id=base, source="variant", run=run,
                  scenario_name=sname, folder=None, variant=case.variant,
                  causal=(case.causal or "").partition(":")[0] or None)
    if scenario is None:
        c.problem = "scenario.json unreadable"
    elif case.template is None or not case.template.verified:
        c.problem = f"variant's scripted ego: {case.template.status if case.template else 'not checked'}"
    else:
        c.scenario = scenario.model_copy(update={"parameters": case.parameters}, deep=True)
    return c


def _views(domain: str):
    """The domain's :class:`~regen.contract.DatasetViews`; LeftOut where it gives none."""
    from regen import domains

    views = domains.make(domain).dataset_views()
    if views is None:
        raise LeftOut("domain gives no samples", f"the {domain} domain draws no dataset frames")
    return views


def simulate_variant(c: Candidate) -> None:
    """Simulate a variant with its scripted ego (a second or so); the trace and verdict go into ``c``."""
    assert c.scenario is not None
    try:
        trace, verdict, judged, error = _views(c.scenario.domain).resimulate(c.scenario)
    except ImportError as exc:  # pragma: no cover - the domain's extra is missing
        c.problem = f"variant not simulated: {exc}"
        return
    if verdict is None or trace is None:
        c.problem = f"variant simulation failed: {error}"
        return
    c.trace, c.verdict, c.scenario = trace, verdict, judged


def check(c: Candidate) -> Label:
    """The candidate's label; LeftOut with the reason it gives no sample."""
    if c.problem:
        raise LeftOut(c.problem.partition(":")[0], c.problem)
    if c.scenario is None or c.verdict is None:
        raise LeftOut("unfinished or unreadable", "no readable scenario.json and verdict.json")
    if c.verdict.status != "verified":
        raise LeftOut(f"verdict {c.verdict.status}", c.verdict.reason)
    if c.causal != "caused":
        why = c.verdict.causal.reason if c.verdict.causal else "no causal check"
        raise LeftOut(f"causal {c.causal or 'missing'}", why)
    if c.trace is None:
        raise LeftOut("no trace", "trace.json missing or unreadable")
    return label(c.scenario, c.trace, c.verdict)


def frame_steps(trace: Trace, t: float) -> list[int]:
    """The trace steps of the frames: :data:`FRAME_OFFSETS` after ``t`` [s], clamped to the trace."""
    return [step_at(trace, max(0.0, t + dt)) for dt in FRAME_OFFSETS]


def privileged(trace: Trace, i: int) -> dict[str, Any]:
    """Every entity at step ``i``: kind, asset, pose [m, rad], speed [m/s], size [m], states."""
    ents = []
    for name, a in sorted(trace.actors.items()):
        states = [{"key": k, "value": None if seq[i] is None else str(seq[i])}
                  for k, seq in sorted(a.states.items()) if not k.startswith(SENSOR_STATES)]
        ents.append({"name": name, "kind": a.kind, "asset": a.asset, "x": round(float(a.x[i]), 4),
                     "y": round(float(a.y[i]), 4), "heading": round(headings(a)[i], 4),
                     "speed": round(speeds(trace, a)[i], 4), "length": a.length, "width": a.width,
                     "height": a.height, "states": states})
    return {"t": round(float(trace.times[i]), 4), "step": i, "entities": ents}


def camera() -> tuple[bool | None, str]:
    """(True, '') where the domain's forward camera renders on this machine, else (None, why not)."""
    note = _views(DOMAIN).camera_note()
    return (None, note) if note else (True, "")


def _map_path(c: Candidate) -> Path | None:
    if c.folder is None:
        return None
    files = ScenarioFolder(c.folder).files()
    xodr = files.get("xodr")
    return c.folder / xodr if xodr and (c.folder / xodr).is_file() else None


def draw(c: Candidate, steps: list[int], cam: bool | None) -> dict[str, Any]:
    """The frames' pictures by relative path: bev_<k>.png, and camera_<k>.png with a camera."""
    assert c.scenario is not None and c.trace is not None and c.verdict is not None
    pictures = _views(c.scenario.domain).pictures(c.scenario, c.trace, c.verdict, steps,
                                                  map_path=_map_path(c), camera=CAMERA_SIZE if cam else None)
    return {f"images/{c.sample_id}/{name}.png": img for name, img in pictures.items()}


def build(c: Candidate, lab: Label, cam: bool | None) -> Sample:
    """A sample of a candidate that passed :func:`check`."""
    assert c.scenario is not None and c.trace is not None and c.verdict is not None
    steps = frame_steps(c.trace, lab.t)
    images = draw(c, steps, cam)
    chain = list(c.scenario.causal_graph)
    ego = ego_name(c.scenario)
    row: dict[str, Any] = {
        "sample_id": c.sample_id, "pair_id": c.pair_id, "source": c.source, "run": c.run,
        "scenario": c.scenario_name, "scenario_id": c.scenario.id, "variant": c.variant, "edits": c.edits,
        "behavior": c.scenario.behavior.text, "ego_template": str(c.scenario.world.get("ego_template") or ""),
        "map": str(c.scenario.world.get("map") or ""), "decision_time": lab.t, "decision_stage": lab.stage,
        "frame_times": [float(c.trace.times[i]) for i in steps],
        "ego_speed": round(speeds(c.trace, c.trace.actors[ego])[steps[-1]], 4),
        "instruction": INSTRUCTION.format(n=len(steps)),
        "action": lab.action, "action_meaning": LABELS[lab.action], "action_evidence": lab.evidence,
        "explanation": f"Cause chain: {' -> '.join(chain)}. {c.scenario.narrative}".strip(),
        "cause_chain": chain, "narrative": c.scenario.narrative,
        "cause_entities": cause_actors(c.scenario, c.trace, c.verdict),
        "verdict_status": c.verdict.status, "causal_status": c.causal or "",
        "privileged": [privileged(c.trace, i) for i in steps],
    }
    for k in range(len(steps)):
        row[f"bev_image_{k}"] = f"images/{c.sample_id}/bev_{k}.png"
        cam_path = f"images/{c.sample_id}/camera_{k}.png"
        row[f"camera_image_{k}"] = cam_path if cam_path in images else None
    qa = layers(c.scenario, c.trace, c.verdict, lab, c.whatifs)
    return Sample(row=row, qa=qa, images=images)


__all__ = ["CAMERA_SIZE", "Candidate", "FRAME_OFFSETS", "INSTRUCTION", "NOT_A_RUN", "Sample", "Skipped", "build",
           "camera", "candidates", "check", "frame_steps", "privileged", "run_folder", "simulate_variant"]
