"""The parameter stage of ``regen falsify`` (:mod:`regen.falsify.params`): VerifAI's samplers
over a scenario's feasible set, the harness's feasible point nearest to unit targets, rho per
variant, determinism, and a clear refusal without VerifAI."""

from __future__ import annotations

import json
import sys

import pytest
from driving_chains import FEASIBLE, verified_run

from regen.harness.cases import CaseResult

CHILD = "01-child-crosses"  # stop_abruptly: a child runs across the road in front of the ego
BUDGET = 4


@pytest.fixture(scope="module")
def _module_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("regen-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(_module_cache, monkeypatch):
    """Overrides the root fixture: the tests of this module share one cache, so the map is
    generated once."""
    monkeypatch.setenv("REGEN_CACHE_DIR", str(_module_cache))


@pytest.fixture(scope="module")
def harness():
    from regen.driving.testing.harness import DrivingHarness

    return DrivingHarness()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A candidate-like run folder: one verified scenario in which constant-speed hits the child."""
    pytest.importorskip("scenic")
    yield from verified_run(tmp_path_factory, {CHILD: FEASIBLE["stop_abruptly"][0]})


def _search(harness, run_dir, policy="constant-speed", seed=0, **kw):
    pytest.importorskip("verifai")
    from regen.falsify.params import search_parameters

    return search_parameters(harness, run_dir, policy, BUDGET, seed, **kw)


def _without_walls(result: dict) -> dict:
    out = {k: v for k, v in result.items() if k != "wall"}
    out["variants"] = [{k: v for k, v in rec.items() if k != "wall"} for rec in result["variants"]]
    return out


# --- the harness: the feasible point nearest to unit targets -------------------------------------


def test_variant_near_moves_to_the_ends_of_each_range_and_stays_feasible(harness):
    from regen.driving.grounding.rules import ground_rule_based
    from regen.driving.testing.variants import feasible_set, feasible_with

    scenario = ground_rule_based(FEASIBLE["stop_abruptly"][0])
    keys = harness.parameter_keys(scenario)
    assert keys and keys == sorted(keys) and all(k[1] in ("s", "v", "t", "d0") for k in keys)
    low = harness.variant_near(scenario, {k: 0.0 for k in keys}, 0)
    high = harness.variant_near(scenario, {k: 1.0 for k in keys}, 0)
    bounds = feasible_set(scenario).bounds
    for variant in (low, high):
        assert feasible_with(scenario, variant.parameters)
        assert variant.entities == scenario.entities and variant.fsm == scenario.fsm
    for actor, name in keys:  # one parameter pulled toward an end, the others held near as grounded
        lo, hi = (harness.variant_near(scenario, {(actor, name): u}, 0).parameters[actor][name] for u in (0.0, 1.0))
        assert lo <= scenario.parameters[actor][name] <= hi and lo < hi
        assert bounds[(actor, name)][0] <= round(lo * 10) and round(hi * 10) <= bounds[(actor, name)][1]
    assert low.parameters != high.parameters
    assert harness.variant_near(scenario, {keys[0]: 0.3}, 0).parameters == \
        harness.variant_near(scenario, {keys[0]: 0.3}, 0).parameters  # seeded: the same answer


def test_a_harness_without_a_parameter_search_says_so(harness, tmp_path):
    from regen.driving.grounding.rules import ground_rule_based
    from regen.harness.contract import NoParameterSearch, PolicyHarness

    scenario = ground_rule_based(FEASIBLE["stop_abruptly"][0])
    with pytest.raises(NoParameterSearch, match="no parameter search"):
        PolicyHarness.parameter_keys(harness, scenario)
    with pytest.raises(NotImplementedError):
        PolicyHarness.variant_near(harness, scenario, {}, 0)


# --- rho ------------------------------------------------------------------------------------------


def test_rho_is_negative_exactly_for_a_failure_and_lowest_for_a_collision():
    from regen.falsify.params import THRESHOLD, robustness

    def case(status, **kw):
        return CaseResult(scenario="s", status=status, **kw)

    assert robustness(case("passed")) == 1.0  # never approached anything
    assert robustness(case("passed", min_distance=2.0, min_ttc=6.0)) == pytest.approx(0.2)  # 2 m of 10 m
    assert robustness(case("passed", min_distance=8.0, min_ttc=0.6)) == pytest.approx(0.2)  # 0.6 s of 3 s
    assert robustness(case("failed", cause="collision", collision=True, min_distance=0.0)) == -1.0
    assert robustness(case("failed", cause="state_not_reached", min_distance=4.0)) == pytest.approx(-0.8)
    assert robustness(case("failed", cause="policy_exception")) == -0.5
    assert all(robustness(case("passed", min_distance=d)) >= THRESHOLD for d in (0.0, 0.5, 50.0))


# --- the search -----------------------------------------------------------------------------------


@pytest.mark.slow
def test_constant_speed_fails_in_most_variants_and_the_worst_is_a_collision(harness, run_dir):
    from regen.runfolder import RunFolder

    result = _search(harness, run_dir)
    json.dumps(result)  # falsify.json stores it as it is
    assert result["ran"] is True and result["verifai"] == "2.2.0" and result["sampler"] == "cross-entropy"
    assert result["budget"] == BUDGET == len(result["variants"]) and result["scenario"] == CHILD
    grounded = RunFolder(run_dir).scenario(CHILD).scenario()
    assert result["keys"] == [f"{a}.{k}" for a, k in harness.parameter_keys(grounded)]
    assert result["valid"] + result["invalid"] == BUDGET and result["valid"] >= 1
    assert result["failing"] >= 1 and result["fail_share"] == round(result["failing"] / result["valid"], 4)
    for rec in result["variants"]:
        assert set(rec["targets"]) == set(result["keys"]) and all(0 <= u <= 1 for u in rec["targets"].values())
        if rec["valid"]:  # the scripted ego verified and hit nothing; the policy's rho judges it
            assert rec["template"]["status"].startswith("verified") and not rec["template"]["collision"]
            assert rec["counterexample"] == (rec["policy"]["status"] == "failed") == (rec["rho"] < 0)
        else:
            assert rec["rho"] == 1.0 and not rec["counterexample"]
    worst = result["worst"]
    assert worst["rho"] == min(r["rho"] for r in result["variants"] if r["valid"]) <= -0.5
    assert worst["cause"] is not None and worst["parameters"]["child1"].keys() >= {"s", "t"}


@pytest.mark.slow
def test_idm_is_more_robust_than_constant_speed(harness, run_dir):
    # under the FSM oracle both fail here (idm slows down but the child is across before it has
    # stopped); the safety oracle asks only that nobody is hit
    careless, careful = (_search(harness, run_dir, policy=p, oracle="safety") for p in ("constant-speed", "idm"))
    assert careless["failing"] >= 1 and careless["worst"]["cause"] == "collision"
    assert careful["ran"] and careful["failing"] == 0 and careful["fail_share"] == 0.0
    assert careful["worst"]["rho"] > careless["worst"]["rho"] and careful["worst"]["cause"] is None


@pytest.mark.slow
def test_the_search_is_deterministic_for_a_seed(harness, run_dir):
    import random

    import numpy as np

    random.seed(123)
    np.random.seed(123)
    outside = random.random(), float(np.random.random())
    random.seed(123)
    np.random.seed(123)
    first = _search(harness, run_dir, seed=5)
    assert (random.random(), float(np.random.random())) == outside  # the caller's generators are untouched
    assert _without_walls(_search(harness, run_dir, seed=5)) == _without_walls(first)
    other = _search(harness, run_dir, seed=6)
    assert [r["targets"] for r in other["variants"]] != [r["targets"] for r in first["variants"]]


@pytest.mark.slow
def test_simulated_annealing_proposes_near_what_it_accepted(harness, run_dir):
    result = _search(harness, run_dir, sampler="simulated-annealing")
    assert result["ran"] and result["sampler"] == "simulated-annealing"
    seen = [list(r["targets"].values()) for r in result["variants"]]
    # VerifAI's proposal: within half its window (at most 1) of the last accepted sample; a
    # uniform draw in several dimensions would rarely stay so close
    for k in range(1, len(seen)):
        assert any(max(abs(a - b) for a, b in zip(seen[k], seen[j], strict=True)) <= 0.5 for j in range(k))


def test_without_verifai_it_says_how_to_install_it(harness, tmp_path, monkeypatch):
    from regen.falsify.params import search_parameters

    monkeypatch.setitem(sys.modules, "verifai", None)  # import verifai raises ImportError
    monkeypatch.setitem(sys.modules, "verifai.samplers", None)
    result = search_parameters(harness, tmp_path, "constant-speed", BUDGET, 0)
    assert result["ran"] is False
    assert result["why"].startswith("VerifAI is not installed")
    assert "pip install --no-deps verifai==2.2.0" in result["why"] and ".[falsify]" in result["why"]


def test_a_scenario_or_harness_without_parameters_to_search_is_not_searched(harness, run_dir, monkeypatch):
    from regen.falsify.params import search_parameters
    from regen.harness.contract import PolicyHarness

    pytest.importorskip("verifai")
    monkeypatch.setattr(type(harness), "parameter_keys", lambda self, scenario: [])
    result = search_parameters(harness, run_dir, "constant-speed", BUDGET, 0)
    assert result == {"ran": False, "why": f"parameter search not run: scenario {CHILD} has no free parameter"}
    monkeypatch.setattr(type(harness), "parameter_keys", PolicyHarness.parameter_keys)  # the contract's default
    result = search_parameters(harness, run_dir, "constant-speed", BUDGET, 0)
    assert result == {"ran": False, "why": "parameter search not run: the DrivingHarness has no parameter search"}
