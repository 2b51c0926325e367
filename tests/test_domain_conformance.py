"""Every registered domain honours the domain contract (in the manner of Gymnasium's check_env):
behavior -> expand -> ground -> simulate -> verify -> render/export -> report through the main
job's own stage functions, with scripted model answers. The ``aisle`` domain exists only in the
tests (tests/support/toydomain): it passes without any edit to the toolkit's shared code.

Grounding calls get an unusable answer on purpose: a domain may fall back to rules then, but the
verdict must say so (``fallbacks``), never pass it silently.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fake_expansion_model import ScriptedModel

from regen import domains
from regen.contract import ANIMATION, KEYFRAMES
from regen.core.behavior import make_behavior
from regen.llm import LLM
from regen.llm.testing import FunctionProvider
from regen.pipeline import generate
from regen.runfolder import RunSettings, ScenarioFolder
from regen.verify import list_predicates

# domain -> (behavior text, cause, entity asset, property choices, free values the model proposes)
EXAMPLES = {
    "driving": ("the ego-vehicle stops abruptly while driving forward", "a child runs across the road",
                "child", {"behavior": ["cross_the_road"], "start_location": ["roadside_ahead"]}, {}),
    "manipulation": ("the robot opens the door", "the pet is waiting outside to come in", "pet",
                     {"location": ["outside the door"]}, {"location": ["outside the door"]}),
    "aisle": ("the robot stops in the aisle", "a worker steps into the aisle", "worker",
              {"behavior": ["step_into_aisle"], "start_location": ["beside_the_aisle_ahead"]}, {}),
}


@pytest.fixture(autouse=True)
def aisle_domain():
    domains.register("aisle", "toydomain:AisleBackend")
    yield
    domains.unregister("aisle")


def _registered() -> list[str]:
    domains.register("aisle", "toydomain:AisleBackend")  # collected before the fixture runs
    try:
        return domains.names()
    finally:
        domains.unregister("aisle")


@pytest.mark.slow
@pytest.mark.parametrize("name", _registered())
def test_domain_runs_the_main_job_end_to_end(name: str, tmp_path: Path) -> None:
    assert name in EXAMPLES, f"a registered domain needs a conformance example: add {name!r} to EXAMPLES"
    cls = domains.backend_class(name)
    pytest.importorskip({"driving": "scenic", "manipulation": "pybullet"}.get(name, "PIL"))
    # declarations
    assert cls.name == name
    assert all(getattr(cls.wording, f).strip() for f in ("expert", "situation", "cause_rule", "value_hint"))
    db = domains.make(name).database()
    text, cause, asset, choose, values = EXAMPLES[name]
    assert asset in db.assets
    library = {p.name for p in list_predicates(name)}
    assert {"stopped", "close_to"} <= library  # the shared predicates hold in every domain

    model = ScriptedModel(causes={text: [cause]}, entities={cause: [asset]}, values=values, choose=choose,
                          otherwise="this is not JSON")
    run = tmp_path / "run"
    behavior = make_behavior(text, name)
    res = generate(behavior, run, settings=RunSettings(max_scenarios=1),
                   llm=LLM(FunctionProvider(model), cache=run / "llm-cache.sqlite"))
    assert res.manifest.status == "done" and len(res.outcomes) == 1
    outcome = res.outcomes[0]
    assert outcome.verdict.feasible, outcome.verdict.reason
    if "other" in model.kinds:  # the domain asked the model while grounding and got nonsense
        assert outcome.verdict.fallbacks, "rules replaced the model's answer without saying so"
    # the domain's files are recorded by role in the run folder, and the report shows them
    folder = ScenarioFolder(outcome.path)
    roles = folder.files()
    assert {ANIMATION, KEYFRAMES} <= set(roles)
    assert all((folder / f).stat().st_size > 0 for f in roles.values())
    report = (run / "report.html").read_text(encoding="utf-8")
    assert roles[ANIMATION] in report and roles[KEYFRAMES] in report
    assert cls.report_hints.animation.replace("'", "&#39;") in report
    summary = json.loads((run / "summary.json").read_text())
    assert summary["feasible"] == 1 and summary["domain"] == name


def test_a_domain_defined_outside_the_toolkit_owns_its_words_and_predicates() -> None:
    from regen.expand.edges import system_prompt
    from regen.verify import get_predicate

    assert "warehouse logistics" in system_prompt("aisle")
    assert get_predicate("in_aisle", "aisle").domains == ("aisle",)
    with pytest.raises(Exception, match="unknown predicate 'in_aisle' for driving"):
        get_predicate("in_aisle", "driving")
