"""Augmenting one scene: the model's proposal (:func:`propose`), each proposal tested as a
counterfactual (:func:`run_augment`), and ``augment.json`` and ``augment.html`` written."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from pydantic import Field

from regen import domains
from regen.core.base import Answer, Model
from regen.core.scenario import Scenario
from regen.errors import ConfigError, RegenError
from regen.whatif import Edit, cast_lines, context_of, judge_root, run_whatif

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.llm import LLM


AUGMENT_JSON = "augment.json"
AUGMENT_HTML = "augment.html"
AUGMENT_PAGE = "augment.html.j2"  # its template among the report's (regen.report.pages)
MAX_ADD = 3


class Proposal(Answer):
    """The model's answer: causes to add and entities it finds irrelevant."""

    add: list[str] = Field(default_factory=list, max_length=6)
    irrelevant: list[str] = Field(default_factory=list, max_length=12)


class Tried(Model):
    """One proposal and what the simulation made of it."""

    proposal: str  # the cause text added, or the entity removed
    folder: str | None = None  # the counterfactual's folder (None: it could not be built)
    status: str  # its verdict's status, or 'not_applied'
    holds: bool  # an addition: it verified; a removal: the behavior is still explained
    reason: str


class Augmentation(Model):
    """``augment.json``."""

    original: str  # the scene's folder (absolute)
    behavior: str
    call_id: str | None = None  # the model call that proposed
    dropped: list[str] = Field(default_factory=list)  # proposals that named nothing in the scene
    additions: list[Tried] = Field(default_factory=list)
    irrelevant: list[Tried] = Field(default_factory=list)


def propose(scenario: Scenario, llm: LLM, db: AssetDatabase) -> tuple[Proposal, str | None]:
    """The model's proposal for ``scenario`` (validated: at most :data:`MAX_ADD` additions)."""
    from regen.templates import render

    prompt = render("regen.augment", "propose", behavior=scenario.behavior.text,
                    cause=scenario.causal_graph[0], cast="\n".join(cast_lines(scenario, db)),
                    assets=", ".join(a.replace("_", " ") for a in db.entities()), max_add=MAX_ADD,
                    first_name=next((e.name for e in context_of(scenario, db)), ""),
                    add_example=domains.backend_class(scenario.domain).wording.augment_example)
    got = llm.ask(prompt, Proposal, purpose="augment")
    p = got.value
    adds = list(dict.fromkeys(" ".join(t.split()) for t in p.add if t.strip()))[:MAX_ADD]
    return Proposal(add=adds, irrelevant=list(dict.fromkeys(n.strip() for n in p.irrelevant if n.strip()))), got.call_id


def run_augment(scenario_dir: str | Path, out: str | Path, llm: LLM, *, judge: LLM | None = None,
                pictures: bool = True, whatif_root: str | Path | None = None,
                on_step=None) -> tuple[Path, Augmentation]:
    """Propose with ``llm``, then test every proposal (see the module docstring); (the folder of
    ``augment.json``, the record). ``whatif_root``: where the counterfactuals go (default
    ``out``); ``on_step(text)``: progress."""
    from regen import domains
    from regen.core.io import atomic_write_text, write_json
    from regen.runfolder import ScenarioFolder, read_model

    src = ScenarioFolder(Path(scenario_dir).absolute())
    got = read_model(src / src.SCENARIO, Scenario, key="scenario")
    if not got.ok:  # the file and what is wrong with it, not only the folder
        raise ConfigError(f"{src / src.SCENARIO} is {got.problem}: {src.path} is not a scenario folder with a "
                          "readable scenario.json (give one of RUN/scenarios/<name>/)")
    scenario = got.value
    backend = domains.make(scenario.domain)
    db = backend.database()
    proposal, call_id = propose(scenario, llm, db)
    present = {e.name for e in context_of(scenario, db)}
    record = Augmentation(original=str(src.path), behavior=scenario.behavior.text, call_id=call_id,
                          dropped=[n for n in proposal.irrelevant if n not in present])
    whatifs = Path(whatif_root) if whatif_root is not None else Path(out)
    tries = [("add", t) for t in proposal.add] + [("remove", n) for n in proposal.irrelevant if n in present]
    for i, (op, what) in enumerate(tries, start=1):
        if on_step is not None:
            on_step(f"{i}/{len(tries)}: {'add' if op == 'add' else 'remove'} {what}")
        edit = Edit(op="add", text=what) if op == "add" else Edit(op="remove", entity=what)
        try:
            dest, w = run_whatif(src.path, [edit], whatifs, pictures=pictures)
        except RegenError as exc:  # the addition names nothing the simulator has, say
            tried = Tried(proposal=what, status="not_applied", holds=False, reason=str(exc))
        else:
            holds, reason = w.explained, w.reason
            if op == "add" and judge is not None:  # recorded beside the simulation's answer, never over it
                judged = judge_root(judge, scenario.domain, [what, scenario.behavior.text])
                if judged["plausible"] is False and holds:
                    reason = (f"{reason}; the model judge finds it no cause of the behavior ({judged['reason']}); "
                              "the simulation decides")
            tried = Tried(proposal=what, folder=str(dest), status=w.status, holds=holds, reason=reason)
        (record.additions if op == "add" else record.irrelevant).append(tried)
    dest = Path(out).absolute() / f"{src.path.name}-augment"
    write_json(dest / AUGMENT_JSON, record)
    atomic_write_text(dest / AUGMENT_HTML, page(record, dest))
    return dest, record


def page(record: Augmentation, dest: Path) -> str:
    """``augment.html``: both lists with their verdicts, linked to each counterfactual's page."""
    from regen.report.pages import page_template

    def href(t: Tried) -> str | None:
        return os.path.relpath(Path(t.folder) / "whatif.html", dest) if t.folder else None

    return page_template(AUGMENT_PAGE).render(
        record=record, additions=[(t, href(t)) for t in record.additions],
        irrelevant=[(t, href(t)) for t in record.irrelevant])



__all__ = ["AUGMENT_HTML", "AUGMENT_JSON", "MAX_ADD", "Augmentation", "Proposal", "Tried", "cast_lines", "page",
           "propose", "run_augment"]
