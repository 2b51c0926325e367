"""Counterfactual what-if: a scenario's cause chain edited, then grounded, simulated and verified again.

The paper's second contribution: perturb the causal graph with a what-if question and see
whether the robot's behavior is still explained. An edit is one of

- ``set``: ``ENTITY.PROPERTY=VALUE`` (``sedan1.brake_lights=broken``; ``truck1.start_location=...``),
  checked against the asset database's values for that asset;
- ``remove``: an entity of the cause chain leaves the scene;
- ``add``: a cause text joins the chain as a new root event, its entities those its words name
  in the database (``a cyclist rides ahead``).

:func:`apply_edits` turns the original scenario's cause path into the counterfactual's: every
entity keeps the values the original scenario had (its behavior, states and start place pinned),
so only what the edits touch changes. :func:`run_whatif` grounds, simulates and verifies the
edited path with the main job's own stage function (:func:`regen.pipeline.stages.run_path`)
into ``OUT/<original>-whatif-<hash>/`` (its own ``scenario.json`` and ``verdict.json``), and writes
``whatif.json`` there: the original's folder (linked, not copied), the edits, both verdicts,
the FSM stages that changed and whether the robot's behavior is still explained (a verified
counterfactual). Removing the cause may leave it unexplained: that is a result, not an error.
``whatif.html`` shows the pair side by side.

A question in words (``--ask``) goes to the model, which answers with edits
(:func:`ask_edits`): data validated by pydantic and by :func:`apply_edits`, never executed.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from regen.core.base import Answer, Model
from regen.errors import ConfigError

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.graph import CausePath
    from regen.core.scenario import Scenario
    from regen.core.verdict import Verdict
    from regen.llm.client import LLM

WHATIF_JSON = "whatif.json"
WHATIF_HTML = "whatif.html"


class Edit(Model):
    """One change to a cause chain."""

    op: Literal["set", "remove", "add"]
    entity: str | None = None  # the scenario's entity name (set, remove)
    property: str | None = None  # set
    value: str | None = None  # set
    text: str | None = None  # add: the new cause event

    def describe(self) -> str:
        if self.op == "set":
            return f"set {self.entity}.{self.property} = {self.value}"
        if self.op == "remove":
            return f"remove {self.entity}"
        return f"add cause '{self.text}'"


class Edits(Answer):
    """The model's answer to a what-if question."""

    edits: list[Edit] = Field(min_length=1, max_length=6)


def parse_set(text: str) -> Edit:
    """``ENTITY.PROPERTY=VALUE`` as an edit; ConfigError saying the shape otherwise."""
    left, eq, value = text.partition("=")
    entity, dot, prop = left.strip().partition(".")
    if not (eq and dot and entity and prop.strip() and value.strip()):
        raise ConfigError(f"--set {text!r}: give ENTITY.PROPERTY=VALUE, e.g. --set sedan1.brake_lights=broken")
    return Edit(op="set", entity=entity.strip(), property=prop.strip(), value=value.strip())


def _cast(scenario: Scenario) -> list[Any]:
    return [e for e in scenario.entities if e.kind != "robot"]


def _actual(entity: Any) -> dict[str, str]:
    """What the original scenario's entity had: its behavior, states and behavior parameters."""
    out = {k: str(v) for k, v in entity.behavior_params.items() if isinstance(v, (str, int, float))}
    out.update({k: str(v) for k, v in entity.properties.items()})
    if entity.behavior:
        out["behavior"] = entity.behavior
    return out


def _pairs(scenario: Scenario, path: CausePath) -> dict[str, int]:
    """Scenario entity name -> index of its path entity (same asset, in order)."""
    used: set[int] = set()
    out: dict[str, int] = {}
    for e in _cast(scenario):
        for i, pe in enumerate(path.entities):
            if i not in used and pe.asset == e.asset:
                out[e.name] = i
                used.add(i)
                break
    return out


def apply_edits(scenario: Scenario, path: CausePath, edits: list[Edit], db: AssetDatabase,
                *, robot: tuple[str, ...] = ()) -> CausePath:
    """The counterfactual's cause path: ``path`` with every entity pinned to the values the
    original ``scenario`` had, then ``edits`` applied. ConfigError naming what is wrong (an
    entity not in the chain, a property or value the asset does not have)."""
    from regen.core.graph import PathEntity

    pairs = _pairs(scenario, path)
    by_name = {e.name: e for e in _cast(scenario)}
    entities = [pe.model_copy(deep=True) for pe in path.entities]
    for name, i in pairs.items():  # unchanged parts kept: the original's own values
        actual = _actual(by_name[name])
        for prop, values in entities[i].properties.items():
            if actual.get(prop) in values:
                entities[i].properties[prop] = [actual[prop]]
            elif len(values) > 1:
                same = [v for v in values if v in actual.values()]
                entities[i].properties[prop] = same[:1] or values
        if "behavior" in actual and "behavior" not in entities[i].properties:
            entities[i].properties["behavior"] = [actual["behavior"]]
    events = list(path.events)
    removed: set[int] = set()
    listing = ", ".join(pairs) or "none"
    for edit in edits:
        if edit.op in ("set", "remove"):
            if edit.entity not in pairs:
                raise ConfigError(f"{edit.describe()}: {edit.entity!r} is not an entity of the cause chain "
                                  f"(its entities: {listing})")
            i = pairs[edit.entity]
        if edit.op == "remove":
            removed.add(i)
        elif edit.op == "set":
            asset = entities[i].asset
            props = db.parameters_of(asset)
            if edit.property not in props:
                raise ConfigError(f"{edit.describe()}: a {asset} has no property {edit.property!r} "
                                  f"(it has: {', '.join(props)})")
            allowed = db.property_candidates(asset, edit.property) if edit.property in db.properties or \
                edit.property == "behavior" else None
            if allowed is not None and edit.value not in allowed:
                raise ConfigError(f"{edit.describe()}: {edit.value!r} is not a value of {edit.property} for a "
                                  f"{asset} (choose one of: {', '.join(allowed)})")
            entities[i].properties[edit.property] = [str(edit.value)]
            before, after = entities[i].event, _reworded(entities[i].event, asset, edit, db)
            events = [after if ev == before else ev for ev in events]
            for pe in entities:  # the entities of the reworded event follow it
                if pe.event == before:
                    pe.event = after
        else:
            text = (edit.text or "").strip()
            if not text:
                raise ConfigError("--add needs a cause text, e.g. --add 'a cyclist rides ahead'")
            named = db.named_assets(text, robot=robot)
            if not named:
                raise ConfigError(f"add cause '{text}': its words name no asset of the {db.name} database; "
                                  "name one (e.g. 'a truck', 'a pedestrian')")
            events.insert(0, text)
            # the states and motion its words name bind it, as they bind a graph's entity
            # ("a traffic light turns red": light_state = turns_red)
            entities += [PathEntity(asset=a, event=text, properties={
                p: [hit[0]] for p in db.parameters_of(a) if (hit := db.named_state(a, p, text)) is not None})
                for a in named]
    kept = [pe for i, pe in enumerate(entities) if i not in removed]
    return path.model_copy(update={"events": events, "entities": kept})


def _reworded(event: str, asset: str, edit: Edit, db: AssetDatabase) -> str:
    """The cause text after a ``set`` edit: the words that named the old state replaced by words
    for the new one ('brake lights on' -> 'broken brake lights'), else those words appended, so
    that the counterfactual's title says what it shows (its fidelity is checked like any other)."""
    prop, value = str(edit.property), str(edit.value)
    spec = db.properties.get(prop)
    phrases = list((spec.named_by or {}).get(value, [])) if spec is not None else []
    new = phrases[0] if phrases else f"{(spec.description if spec is not None else prop)} {value}".strip()
    old = db.named_states(asset, prop, event) if prop in db.properties else {}
    if old:
        out = event
        for phrase in old.values():
            # the new words in the old words' form where there are some ('turns red' -> 'turns green')
            head = phrase.split()[0].lower()
            alike = next((p for p in phrases if p.split()[0].lower() == head), new)
            out = re.sub(re.escape(phrase), alike, out, flags=re.IGNORECASE)
        return out
    return f"{event} ({new})" if new.lower() not in event.lower() else event


def ask_edits(scenario: Scenario, question: str, llm: LLM, db: AssetDatabase) -> list[Edit]:
    """The model's edits for a what-if question about ``scenario`` (validated, not applied)."""
    from regen.templates import render

    cast = []
    for e in _cast(scenario):
        values = {p: db.property_candidates(e.asset, p) for p in db.parameters_of(e.asset)
                  if p in db.properties or p == "behavior"}
        have = _actual(e)
        cast.append({"name": e.name, "asset": e.asset,
                     "properties": {p: {"now": have.get(p), "values": v} for p, v in values.items() if v}})
    prompt = render("regen.whatif", "ask", question=question, cause=scenario.causal_graph[0],
                    cast=json.dumps(cast, indent=1))
    got = llm.ask(prompt, Edits, purpose="whatif")
    return list(got.value.edits)


def stage_lines(scenario: Scenario) -> list[str]:
    """The FSM stages in words: 'child1 waiting and ego driving'."""
    return [" and ".join(f"{c.actor} {c.state}" for c in stage.conditions) for stage in scenario.fsm.stages]


def changed_stages(before: Scenario, after: Scenario | None) -> list[dict[str, str | None]]:
    """Stages that differ, by position: {'index', 'before', 'after'}."""
    a, b = stage_lines(before), stage_lines(after) if after is not None else []
    out = []
    for k in range(max(len(a), len(b))):
        x, y = (a[k] if k < len(a) else None), (b[k] if k < len(b) else None)
        if x != y:
            out.append({"index": str(k + 1), "before": x, "after": y})
    return out


class WhatIf(Model):
    """``whatif.json``: a counterfactual and what it is the counterfactual of."""

    original: str  # the original scenario folder (absolute)
    question: str | None = None  # --ask, when the edits came from the model
    edits: list[Edit]
    edits_by: Literal["user", "model"] = "user"
    call_id: str | None = None  # the model call that wrote the edits
    original_status: str
    status: str  # the counterfactual's verdict
    #: the robot's behavior is still explained: the counterfactual's FSM played out and its cause
    #: caused the behavior (the but-for check with the reference robot, :mod:`regen.verify.causal`;
    #: where the domain cannot check, the FSM alone, and ``causal`` says 'not_checked')
    explained: bool
    causal: str | None = None  # the counterfactual's causal status
    original_causal: str | None = None  # the original's
    #: the event judge on the counterfactual's root cause ({'by', 'plausible', 'reason'}); by
    #: 'none' when no model judged it. Recorded beside the simulation's answer, never over it
    judged: dict[str, Any] = Field(default_factory=lambda: {"by": "none", "plausible": None, "reason": ""})
    original_explained: bool
    reason: str
    stages_changed: list[dict[str, str | None]] = Field(default_factory=list)
    #: For each property an edit set: the states the entity showed in each run, in order of
    #: first appearance ({'entity', 'property', 'before', 'after'}): what the pictures show.
    shown_states: list[dict[str, str]] = Field(default_factory=list)


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


def _picture(folder: Path, dest: Path) -> str | None:
    """The folder's animation (its files.json role), relative to ``dest``."""
    from regen.contract import ANIMATION
    from regen.runfolder import ScenarioFolder

    name = ScenarioFolder(folder).files().get(ANIMATION)
    return os.path.relpath(folder / name, dest) if name else None


def page(record: WhatIf, original: Path, dest: Path, before: Scenario, after: Scenario | None) -> str:
    """``whatif.html``: the pair side by side (pictures, verdicts, stages, edits)."""
    from regen.templates import environment

    return environment("regen.whatif", html=True).get_template("page.j2").render(record=record, cause=before.causal_graph[0],
                  after_cause=after.causal_graph[0] if after is not None else "(not grounded)",
                  behavior=before.behavior.text,
                  before_gif=_picture(original, dest), after_gif=_picture(dest, dest),
                  before_stages=stage_lines(before), after_stages=stage_lines(after) if after else [],
                  original_href=os.path.relpath(original, dest))


__all__ = ["WHATIF_HTML", "WHATIF_JSON", "Edit", "Edits", "WhatIf", "apply_edits", "ask_edits",
           "changed_stages", "parse_set", "run_whatif"]
