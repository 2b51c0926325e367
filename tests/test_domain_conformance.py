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


def test_a_domain_needs_only_ground_simulate_render_and_its_words(tmp_path: Path) -> None:
    """The optional parts are capability objects (or None) and restrictions: the aisle domain
    defines none of them, and the commands that need one refuse it in one line."""
    from regen.contract import DomainBackend
    from regen.errors import ConfigError
    from regen.pipeline.imports import backend_for, import_file

    assert DomainBackend.__abstractmethods__ == {"ground", "simulate", "render"}
    cls = domains.backend_class("aisle")
    assert not {"importer", "recorder", "property_choices", "policy_harness", "typology"} & set(vars(cls))
    aisle = domains.make("aisle")
    assert aisle.importer() is None and aisle.recorder() is None and aisle.policy_harness() is None
    assert aisle.typology() is None
    assert aisle.property_choices("worker") is None
    xosc = tmp_path / "s.xosc"
    xosc.write_text("<OpenSCENARIO/>")
    with pytest.raises(ConfigError, match="the aisle domain imports no files, not .xosc"):
        backend_for(xosc, "aisle")
    (tmp_path / "s.aisle").write_text("x")
    with pytest.raises(ConfigError, match=r"no domain imports \.aisle files; regen import reads \.xosc$"):
        import_file(tmp_path / "s.aisle", tmp_path / "run")  # the suffixes over every domain
    with pytest.raises(ConfigError, match=r"no such file; give a scenario file \(\.xosc\)"):
        import_file(tmp_path / "gone.xosc", tmp_path / "run")
    assert backend_for(xosc).name == "driving"


def test_a_domain_without_a_recorder_refuses_a_recorded_trajectory(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from regen.cli import app

    f = tmp_path / "ego.csv"
    f.write_text("t,x,y\n0,0,0\n0.1,1,0\n")
    res = CliRunner().invoke(app, ["generate", "-d", "aisle", "--ego-trajectory", str(f), "--out",
                                   str(tmp_path / "run"), "--replay"])
    assert res.exit_code == 2, res.output
    assert "the aisle domain takes no recorded trajectory; give the behavior as text" in res.output


def test_a_recorder_refuses_an_option_it_does_not_take(tmp_path: Path) -> None:
    from regen.errors import ConfigError

    recorder = domains.make("driving").recorder()
    assert set(recorder.options) == {"map"}
    with pytest.raises(ConfigError, match="no option 'lane'.*map: the generated map"):
        recorder.read(tmp_path / "ego.csv", options={"lane": "2"})


def test_property_choices_without_a_key_hold_one_entry() -> None:
    from regen.contract import PropertyChoices

    fixed = PropertyChoices.fixed({"power": ["off"]})
    assert fixed.key is None and fixed.alternatives(None) == [{"power": ["off"]}]
    assert fixed.dependent() == {"power"}
    with pytest.raises(ValueError, match="one entry, under None"):
        PropertyChoices(None, {"x": {"power": ["off"]}})
    keyed = PropertyChoices("behavior", {"walk": [{"speed": ["slow"]}, {"speed": ["fast"], "start": ["a"]}],
                                         "stand": {}})
    assert keyed.alternatives("walk")[1]["start"] == ["a"] and keyed.alternatives("run") == [None]
    assert keyed.dependent() == {"speed", "start"}
