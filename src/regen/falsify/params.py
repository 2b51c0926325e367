"""The parameter stage of ``regen falsify``: how robust a found failure is over its scenario's
feasible set.

A finding of the edit search is a candidate run with one scenario in which the policy fails.
:func:`search_parameters` samples ``budget`` other points of that scenario's CP-SAT feasible set
with one of VerifAI's samplers (PyPI ``verifai``; a sampler, not an optimiser of our own) and
tests the policy in each, which says whether the failure is a knife-edge or holds across the
parameters, and which variant is the worst.

The search space is the unit box, one axis per key of the harness's
:meth:`~regen.harness.contract.PolicyHarness.parameter_keys`; a sampled point is a target per
parameter, which the harness turns into the feasible variant nearest to it
(:meth:`~regen.harness.contract.PolicyHarness.variant_near`). Each variant is run as ``regen
test`` runs a case: the scripted robot first (:meth:`~regen.harness.contract.PolicyHarness.check_template`;
a variant in which it does not verify or collides tests nothing and is *invalid*), then the policy
in its own process (:class:`regen.harness.process.PolicyProcess`, started once for the search),
judged by :func:`regen.harness.oracle.judge`.

Robustness rho of a variant (VerifAI's convention: rho < :data:`THRESHOLD` is a counterexample),
from the policy's case: with the closeness ``c = min(1, min_distance / DISTANCE_SCALE,
min_ttc / TTC_SCALE)`` (a figure the case lacks counts as 1: never approached; a collision makes
``c`` 0),

- passed: ``rho = c``, in [0, 1]: how near the policy came to failing;
- failed (a collision, a policy fault, an incident, an FSM state not reached): ``rho = c / 2 - 1``,
  in [-1, -0.5]; a collision is -1, the lowest;
- invalid (no feasible variant, the scripted robot does not verify or collides, the simulator
  fails): :data:`INVALID_RHO`, fed to the sampler as a pass and counted apart.

The samplers draw from the global ``random`` and ``numpy.random`` generators; the search keeps
their state of its own, seeded by ``seed``, and swaps it in only around the sampler's calls, so
the simulator's use of those generators changes nothing and the caller's state is left as it
was: the result is the same for the same seed. The cross-entropy sampler learns only from
counterexamples and draws more of them as it goes, so ``fail_share`` is the share among the
variants it drew, not of the feasible set's volume.
"""

from __future__ import annotations

import contextlib
import math
import random
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from regen.core.scenario import Scenario
from regen.errors import ConfigError, RegenError, install_hint
from regen.harness.cases import CaseResult
from regen.harness.contract import NoParameterSearch, PolicyHarness, TemplateRun

VERIFAI = "verifai==2.2.0"
THRESHOLD = 0.0  # rho below this is a counterexample (VerifAI's samplers' convention)
DISTANCE_SCALE = 10.0  # [m] a gap this wide or wider is as safe as never approaching
TTC_SCALE = 3.0  # [s] a time to collision this long or longer is as safe as never approaching
INVALID_RHO = 1.0  # fed for an invalid variant: the sampler learns nothing from it
#: the simulated annealing sampler's settings: start temperature (rho spans [-1, 1]), how fast
#: the proposal window narrows per step, and epochs enough that it never runs out within a budget
SA_TEMPERATURE = 0.5
SA_DECAY = 0.8

Key = tuple[str, str]


def robustness(case: CaseResult) -> float:
    """rho of a judged case (see the module docstring): in [0, 1] when it passed, in [-1, -0.5]
    when it failed, -1 for a collision."""
    close = 1.0
    if case.collision:
        close = 0.0
    else:
        for value, scale in ((case.min_distance, DISTANCE_SCALE), (case.min_ttc, TTC_SCALE)):
            if value is not None and math.isfinite(value):
                close = min(close, max(0.0, value) / scale)
    return round(close if case.passed else close / 2 - 1.0, 4)


def _verifai() -> tuple[Any, str] | str:
    """(the ``verifai`` package, its version), or why it cannot be used."""
    from importlib.metadata import version

    try:
        import verifai
        import verifai.samplers  # noqa: F401 - the samplers import scenic, dotmap, dill, networkx
    except ImportError as exc:
        return (f"VerifAI is not installed ({exc}): install it with 'pip install --no-deps {VERIFAI}' "
                f"and its samplers' dependencies with {install_hint('falsify')}")
    try:
        found = version("verifai")
    except Exception:  # noqa: BLE001 - a package importable without metadata (on sys.path by hand)
        found = getattr(verifai, "__version__", "unknown")
    return verifai, found


def _cross_entropy(verifai: Any, space: Any, budget: int) -> Any:
    return verifai.samplers.FeatureSampler.crossEntropySamplerFor(space)


def _simulated_annealing(verifai: Any, space: Any, budget: int) -> Any:
    from dotmap import DotMap

    params = DotMap(T=SA_TEMPERATURE, decay_rate=SA_DECAY, iterations=budget, num_epoch=budget + 1)
    return verifai.samplers.FeatureSampler.simulatedAnnealingSamplerFor(space, params)


#: sampler name -> how to make it over a feature space (VerifAI's own constructors)
SAMPLERS: dict[str, Callable[[Any, Any, int], Any]] = {
    "cross-entropy": _cross_entropy,
    "simulated-annealing": _simulated_annealing,
}


def _annealers(verifai: Any, sampler: Any) -> list[Any]:
    """The SimulatedAnnealingSampler inside a feature sampler (none for other samplers)."""
    inner = getattr(sampler, "domainSampler", None)
    return [s for s in getattr(inner, "samplers", ()) if isinstance(s, verifai.samplers.SimulatedAnnealingSampler)]


@contextlib.contextmanager
def _global_rngs_kept() -> Iterator[None]:
    """The global ``random`` and ``numpy.random`` states as they were before, afterwards."""
    outside = random.getstate(), np.random.get_state()
    try:
        yield
    finally:
        random.setstate(outside[0])
        np.random.set_state(outside[1])


class _Rng:
    """The samplers' own ``random`` and ``numpy.random`` state, swapped in around their calls."""

    def __init__(self, seed: int) -> None:
        with _global_rngs_kept():
            random.seed(seed)
            np.random.seed(seed % 2**32)
            self.state = random.getstate(), np.random.get_state()

    @contextlib.contextmanager
    def inside(self) -> Iterator[None]:
        with _global_rngs_kept():
            random.setstate(self.state[0])
            np.random.set_state(self.state[1])
            try:
                yield
            finally:
                self.state = random.getstate(), np.random.get_state()


def _label(key: Key) -> str:
    return f"{key[0]}.{key[1]}"


def _values(scenario: Scenario, keys: list[Key]) -> dict[str, dict[str, float]]:
    """The searched parameters' values in a variant, per entity."""
    out: dict[str, dict[str, float]] = {}
    for actor, name in keys:
        value = scenario.parameters.get(actor, {}).get(name)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            out.setdefault(actor, {})[name] = float(value)
    return out


def _template(run: TemplateRun) -> tuple[bool, dict[str, Any]]:
    """Whether the variant tests anything (the scripted robot verified and hit nothing), and its
    run in words (``regen test``'s own check)."""
    from regen.harness.suite import template_check

    check = template_check(run)
    return check.verified and not check.collision, {
        "status": check.status, "collision": check.collision, "message": check.message}


def _scenario(candidate_run: Path, name: str | None) -> tuple[str, Scenario]:
    """The scenario folder searched: ``name``, else the run's only one; ConfigError otherwise."""
    from regen.runfolder import RunFolder

    rf = RunFolder(candidate_run)
    names = rf.scenario_names()
    if name is None:
        if len(names) != 1:
            raise ConfigError(f"{candidate_run} holds {len(names)} scenario folders, not one: name the one "
                              "to search")
        name = names[0]
    elif name not in names:
        raise ConfigError(f"{candidate_run} has no scenario folder {name!r}")
    scenario = rf.scenario(name).scenario()
    if scenario is None:
        raise ConfigError(f"{candidate_run}/{rf.SCENARIOS}/{name} holds no readable scenario.json")
    return name, scenario


class _Search:
    """What every variant of one search shares: the harness, the scenario, its keys, the policy's
    process and the settings."""

    def __init__(self, harness: PolicyHarness, scenario: Scenario, name: str, keys: list[Key], remote: Any,
                 *, seed: int, oracle: str, step_timeout: float) -> None:
        self.harness, self.scenario, self.name, self.keys = harness, scenario, name, keys
        self.remote, self.seed, self.oracle, self.step_timeout = remote, seed, oracle, step_timeout

    def variant(self, k: int, unit: list[float]) -> dict[str, Any]:
        """The record of one variant: its targets, parameters, the scripted robot, the policy, rho."""
        targets = dict(zip(self.keys, unit, strict=True))
        rec: dict[str, Any] = {"index": k, "targets": {_label(key): round(u, 4) for key, u in targets.items()},
                               "parameters": None, "template": None, "policy": None, "valid": False,
                               "rho": INVALID_RHO, "counterexample": False, "wall": {}}
        t0 = time.perf_counter()
        try:
            variant = self.harness.variant_near(self.scenario, targets, self.seed)
        except Exception as exc:  # noqa: BLE001 - one variant that cannot be solved is one invalid variant
            rec["error"] = f"no variant: {type(exc).__name__}: {exc}"
            return rec
        rec["wall"]["solve"] = round(time.perf_counter() - t0, 3)
        if variant is None:
            rec["error"] = "no feasible variant near these targets"
            return rec
        rec["parameters"] = _values(variant, self.keys)
        t0 = time.perf_counter()
        try:
            template = self.harness.check_template(variant)
        except Exception as exc:  # noqa: BLE001 - as regen test: a variant that cannot be checked tests nothing
            template = TemplateRun(verdict=None, judged=variant, error=f"{type(exc).__name__}: {exc}")
        rec["wall"]["template"] = round(time.perf_counter() - t0, 3)
        valid, rec["template"] = _template(template)
        if not valid:
            return rec
        t0 = time.perf_counter()
        try:
            case = self.run_policy(template.judged or variant, k, template.trace)
        except Exception as exc:  # noqa: BLE001 - the simulator's fault is this variant's, not the policy's
            rec["error"] = f"the policy's episode could not be run: {type(exc).__name__}: {exc}"
            return rec
        rec["wall"]["policy"] = round(time.perf_counter() - t0, 3)
        rho = robustness(case)
        rec.update(valid=True, rho=rho, counterexample=rho < THRESHOLD, policy={
            "status": case.status, "cause": case.cause, "message": case.message,
            "min_distance": case.min_distance, "min_ttc": case.min_ttc})
        return rec

    def run_policy(self, scenario: Scenario, k: int, template_trace: Any) -> CaseResult:
        """The policy in one variant, judged as ``regen test`` judges a case."""
        from regen.harness.suite import run_case

        self.remote.ensure_fresh()  # a policy that faulted in the last variant starts afresh
        case, _, _ = run_case(self.harness, self.remote, scenario, name=self.name, variant=k,
                              timeout=self.step_timeout, oracle=self.oracle, template_trace=template_trace)
        return case


def _summary(variants: list[dict[str, Any]]) -> dict[str, Any]:
    valid = [v for v in variants if v["valid"]]
    failing = [v for v in valid if v["counterexample"]]
    worst = min(valid, key=lambda v: (v["rho"], v["index"]), default=None)
    return {
        "valid": len(valid), "invalid": len(variants) - len(valid), "failing": len(failing),
        "fail_share": round(len(failing) / len(valid), 4) if valid else None,
        "worst": None if worst is None else {
            "index": worst["index"], "parameters": worst["parameters"], "rho": worst["rho"],
            "cause": worst["policy"]["cause"], "message": worst["policy"]["message"]},
    }


def _sample(verifai: Any, sampler: str, budget: int, seed: int, search: _Search) -> list[dict[str, Any]]:
    """``budget`` variants drawn by the sampler, each fed back to it with its rho."""
    rng = _Rng(seed)
    space = verifai.features.FeatureSpace({"targets": verifai.features.Feature(
        verifai.features.Box(*[(0.0, 1.0)] * len(search.keys)))})
    with rng.inside():
        drawer = SAMPLERS[sampler](verifai, space, budget)
    variants = []
    for k in range(budget):
        with rng.inside():
            point, info = drawer.getSample()
        rec = search.variant(k, [float(u) for u in point.targets])
        variants.append(rec)
        with rng.inside():
            drawer.update(point, info, rec["rho"])
        for annealer in _annealers(verifai, drawer):
            # VerifAI 2.2.0 clears this flag only for a rho of None, which its own update asserts
            # never comes after a sample: left set, every sample would be a fresh uniform draw
            annealer.is_first_sample = False
    return variants


def search_parameters(harness: PolicyHarness, candidate_run: Path, policy_spec: str, budget: int, seed: int,
                      *, sampler: str = "cross-entropy", oracle: str = "fsm", scenario: str | None = None,
                      step_timeout: float | None = None) -> dict[str, Any]:
    """Test ``policy_spec`` in ``budget`` variants of the candidate run's scenario drawn by a
    VerifAI ``sampler`` ('cross-entropy' or 'simulated-annealing') and say how robust its failure is.

    Returns a JSON-able dict: ``ran`` (False with ``why`` when VerifAI is not installed, the
    harness has no parameter search, the scenario has no free parameter or the policy does not
    load); ``sampler``, ``verifai`` (its version), ``budget``, ``seed``, ``keys`` (the searched
    ``entity.parameter`` axes) and ``units``, ``threshold``; ``valid``, ``invalid``, ``failing``
    (valid variants with rho < threshold), ``fail_share`` (failing / valid, None without a valid
    one), ``worst`` (the valid variant of lowest rho: ``index``, ``parameters``, ``rho``,
    ``cause``, ``message``; None without a valid one), ``variants`` (per variant: ``targets`` in
    the unit box, the solved ``parameters``, the scripted robot's ``template`` status, the
    ``policy``'s status and cause, ``valid``, ``rho``, ``counterexample``, ``wall`` [s] per part,
    and ``error`` where the variant could not be solved or run), and
    ``wall`` [s] of the whole search. Deterministic for ``seed``.

    ``scenario``: the scenario folder to search (default: the run's only one). ``oracle``: as
    ``regen test --oracle``. ConfigError for a bad budget, sampler, oracle or run folder.
    """
    from regen.harness.oracle import ORACLES
    from regen.harness.process import PolicyProcess

    if oracle not in ORACLES:
        raise ConfigError(f"unknown oracle {oracle!r}; choose one of: {', '.join(ORACLES)}")
    if budget < 1:
        raise ConfigError(f"the parameter search's budget must be at least 1 (got {budget})")
    if sampler not in SAMPLERS:
        raise ConfigError(f"unknown sampler {sampler!r}; choose one of: {', '.join(SAMPLERS)}")
    found = _verifai()
    if isinstance(found, str):
        return {"ran": False, "why": found}
    verifai, version = found
    start = time.perf_counter()
    name, grounded = _scenario(Path(candidate_run), scenario)
    try:
        keys = [tuple(k) for k in harness.parameter_keys(grounded)]
    except (NoParameterSearch, RegenError) as exc:
        return {"ran": False, "why": f"parameter search not run: {exc}"}
    if not keys:
        return {"ran": False, "why": f"parameter search not run: scenario {name} has no free parameter"}
    remote = PolicyProcess(harness, policy_spec)
    try:
        remote.start()
    except RegenError as exc:
        return {"ran": False, "why": f"parameter search not run: {exc}"}
    search = _Search(harness, grounded, name, keys, remote, seed=seed, oracle=oracle,
                     step_timeout=harness.step_timeout if step_timeout is None else step_timeout)
    try:
        with _global_rngs_kept():  # the simulator may draw from them too
            variants = _sample(verifai, sampler, budget, seed, search)
    finally:
        remote.close()
    units = harness.parameter_units
    return {"ran": True, "scenario": name, "policy": policy_spec, "oracle": oracle, "sampler": sampler,
            "verifai": version, "budget": budget, "seed": seed, "threshold": THRESHOLD,
            "keys": [_label(k) for k in keys], "units": {_label(k): units.get(k[1], "") for k in keys},
            **_summary(variants), "variants": variants, "wall": round(time.perf_counter() - start, 3)}


__all__ = ["DISTANCE_SCALE", "INVALID_RHO", "SAMPLERS", "THRESHOLD", "TTC_SCALE", "robustness",
           "search_parameters"]
