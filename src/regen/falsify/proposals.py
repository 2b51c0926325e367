"""The model's part in ``regen falsify --llm``: new causes to add, suggested by the failures
found so far. The answer is data (a short list of cause texts), validated by pydantic and by the
asset database (each text must name an asset, as :func:`regen.whatif.apply_edits` requires of an
``add``); model text is never executed."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from pydantic import Field

from regen import domains
from regen.core.base import Answer
from regen.falsify.record import ModelRound
from regen.whatif import cast_lines

if TYPE_CHECKING:
    from regen.assets.database import AssetDatabase
    from regen.core.scenario import Scenario
    from regen.llm.client import LLM

MAX_CAUSES = 3  # causes taken per source scenario


class Causes(Answer):
    """The model's answer: cause events to add to the scene."""

    causes: list[str] = Field(default_factory=list, max_length=6)


def propose_causes(scenario: Scenario, name: str, llm: LLM, db: AssetDatabase, *, policy: str,
                   failures: Sequence[str], tried: Sequence[str], robot: Sequence[str] = ()) -> ModelRound:
    """Ask the model for causes to add to ``scenario`` (the source scenario's folder ``name``),
    shown the cast and ``failures`` (edits in words, with how the policy failed). Each cause is
    kept when its words name an asset of the database (the robot's words and its own task objects
    excluded) and it is not among ``tried``; the others are recorded with why not."""
    from regen.templates import render

    backend = domains.backend_class(scenario.domain)
    prompt = render("regen.falsify", "causes", robot=backend.report_hints.robot, policy=policy,
                    behavior=scenario.behavior.text, cause=scenario.causal_graph[0],
                    cast="\n".join(cast_lines(scenario, db)) or "(none)",
                    assets=", ".join(a.replace("_", " ") for a in db.entities()),
                    failures=list(failures), max_causes=MAX_CAUSES, add_example=backend.wording.add_example,
                    tried="; ".join(f'"{t}"' for t in tried) or "none")
    got = llm.ask(prompt, Causes, purpose="falsify")
    own = frozenset(domains.make(scenario.domain).own_objects(scenario.behavior))
    seen = {" ".join(t.lower().split()) for t in tried}
    out = ModelRound(scenario=name, call_id=got.call_id)
    for raw in got.value.causes:
        text = " ".join(raw.split())
        key = text.lower()
        if not text or key in seen:
            if text:
                out.rejected[text] = "already tried"
            continue
        if len(out.causes) >= MAX_CAUSES:
            out.rejected[text] = f"more than {MAX_CAUSES} causes"
            continue
        if not db.named_assets(text, robot=tuple(robot), own=own):
            out.rejected[text] = f"its words name no asset of the {db.name} database"
            continue
        seen.add(key)
        out.causes.append(text)
    return out


__all__ = ["MAX_CAUSES", "Causes", "propose_causes"]
