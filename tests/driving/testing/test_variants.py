"""Parameter variants from the solved feasible set (``--variants N``) and the adversarial search
(``--adversarial``): feasible, seeded, distinct; one test case per variant; corner cases that
make constant-speed fail while the scripted template ego verifies and collides with nothing."""

from __future__ import annotations

import json
import textwrap
import xml.etree.ElementTree as ET

import pytest
from driving_chains import FEASIBLE, verified_run  # noqa: E402

from regen.driving.grounding.rules import ground_rule_based  # noqa: E402
from regen.driving.testing.variants import feasible_with, sample_parameters, sample_variants  # noqa: E402

CHILD = "01-child-crosses"  # stop_abruptly: a child runs across the road in front of the ego
CHAINS = [pytest.param(key, i, id=f"{key}-{i}") for key, paths in FEASIBLE.items() for i in range(len(paths))]


@pytest.mark.parametrize(("key", "i"), CHAINS)
def test_variants_are_feasible_seeded_and_distinct(key, i):
    scenario = ground_rule_based(FEASIBLE[key][i])
    assert scenario.solver.status in ("optimal", "feasible")
    found = sample_variants(scenario, 4, seed=3)
    assert found[0] is scenario  # variant 0: as grounded
    assert [v.parameters for v in sample_variants(scenario, 4, seed=3)] == [v.parameters for v in found]
    params = [v.parameters for v in found]
    assert all(feasible_with(scenario, p) for p in params)  # pinned, the model stays feasible
    assert all(v.entities == scenario.entities and v.fsm == scenario.fsm for v in found)
    if any(p for p in scenario.parameters.values()):  # (a scenario may have no free parameter)
        assert len(found) == 4
        assert len({json.dumps(p, sort_keys=True) for p in params}) == 4
    for p in sample_parameters(scenario, 4, seed=3, extremes=True):
        assert feasible_with(scenario, p)


def test_another_seed_gives_other_variants_and_one_variant_is_the_scenario():
    scenario = ground_rule_based(FEASIBLE["stop_abruptly"][0])
    a = sample_parameters(scenario, 3, seed=0)
    b = sample_parameters(scenario, 3, seed=1)
    assert a[0] == b[0] == scenario.parameters and a[1:] != b[1:]
    assert sample_variants(scenario, 1) == [scenario]
    moved = {"child1": {**scenario.parameters["child1"], "s": 0.0}}  # not ahead of the ego: infeasible
    assert not feasible_with(scenario, moved)


# --- in the loop (real Scenic) --------------------------------------------------------------------


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A run folder with one verified scenario."""
    pytest.importorskip("scenic")
    yield from verified_run(tmp_path_factory, {CHILD: FEASIBLE["stop_abruptly"][0]})


@pytest.mark.slow
def test_three_variants_are_three_test_cases(run_dir, tmp_path):
    from regen.harness.junit import write_report
    from regen.harness.suite import run_tests
    from regen.runfolder import RunFolder

    report = run_tests(run_dir, "constant-speed", variants=3, seed=0)
    assert [c.variant for c in report.cases] == [0, 1, 2] and report.variants == 3
    grounded = RunFolder(run_dir).scenario(CHILD).scenario()
    assert report.cases[0].parameters == grounded.parameters
    assert len({json.dumps(c.parameters, sort_keys=True) for c in report.cases}) == 3
    for c in report.cases:  # the template ego was checked in each variant; none is skipped
        assert c.template is not None and c.template.verified and c.status != "skipped", c.message
    assert report.summary()["tests"] == 3
    assert report.collision_line() == f"collision rate: {report.summary()['collisions']}/3"
    files = write_report(report, tmp_path / "out")
    cases = list(ET.parse(files["junit"]).getroot().iter("testcase"))
    assert [tc.get("name") for tc in cases] == [f"{CHILD}[variant {k}]" for k in range(3)]
    props = {p.get("name"): p.get("value") for p in cases[1].iter("property")}
    assert float(props["child1.s"]) == report.cases[1].parameters["child1"]["s"]
    assert props["template"] == "verified"
    data = json.loads(files["tests"].read_text())
    assert [c["parameters"] for c in data["cases"]] == [c.parameters for c in report.cases]


@pytest.mark.slow
def test_a_variant_whose_template_ego_fails_is_skipped(run_dir, monkeypatch):
    from regen.driving.testing import variants
    from regen.harness.suite import run_tests

    monkeypatch.setattr(variants, "check_template", lambda scenario: variants.TemplateRun(
        verdict=None, trace=None, judged=scenario, error="SimulationError: boom"))
    report = run_tests(run_dir, "constant-speed", variants=2)
    first, second = report.cases
    assert first.status == "failed" and second.status == "skipped"
    assert "does not verify" in second.message and "boom" in second.message
    assert second.template.status == "simulation_failed"
    assert report.summary()["tests"] == 1 and report.summary()["skipped"] == 1


@pytest.mark.slow
def test_adversarial_finds_a_corner_case_the_template_ego_avoids(run_dir, tmp_path):
    from typer.testing import CliRunner

    from regen.harness.cli import make_app

    out = tmp_path / "adv"
    res = CliRunner().invoke(make_app(), [str(run_dir), "--policy", "constant-speed", "--adversarial",
                                          "--variants", "3", "--out", str(out)])
    assert res.exit_code == 1, res.output
    assert f"FAIL  {CHILD}[variant 0]" in res.output and "adversarial: " in res.output
    data = json.loads((out / "tests.json").read_text())
    assert data["adversarial"] is True and len(data["cases"]) == 3
    assert all(c["adversarial"] for c in data["cases"])
    found = [c for c in data["cases"] if c["status"] == "failed"]
    assert any(c["variant"] > 0 for c in found)  # the search, not only the scenario as grounded
    for c in found:  # the policy fails where the scripted template ego verified and hit nothing
        assert c["template"]["verified"] and not c["template"]["collision"]
        assert c["parameters"]["child1"].keys() >= {"s", "v", "t"}
    assert any(c["collision"] and c["collision_with"] == "child1" for c in found)
    assert "child1 s=" in res.output  # each failing variant's parameters on the terminal


@pytest.mark.slow
def test_adversarial_reports_none_for_a_policy_that_always_yields(run_dir, tmp_path):
    from regen.driving.testing.policies import load_policy
    from regen.harness.adversarial import failing, summary_lines
    from regen.harness.suite import run_tests

    f = tmp_path / "brake_early.py"
    f.write_text(textwrap.dedent("""
        from regen.driving.testing.policies import Action, route_curvature

        def policy(obs):
            # brake to a stop whenever a pedestrian is within 30 m
            near = any(a.category == "pedestrian" and abs(a.x - obs.ego.x) < 30 for a in obs.actors)
            return Action(-6.0 if near else 0.0, route_curvature(obs.ego))
    """))
    spec = f"{f}:policy"
    report = run_tests(run_dir, spec, policy=load_policy(spec), variants=3, oracle="safety", adversarial=True)
    assert len(report.cases) == 3 and all(c.status == "passed" for c in report.cases)
    assert failing(report) == []
    assert "no failing variant found" in "\n".join(summary_lines(report))
