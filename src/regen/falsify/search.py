"""The search of ``regen falsify``: over a run's causes, for what makes a policy fail.

From the run's verified scenarios (``caused`` ones first), breadth-first by size within a budget
of candidates (each grounded, simulated and tested: :mod:`regen.falsify.candidate`):

0. each scenario as generated, with no edit (the baseline): where the policy fails already, that
   failure is the scenario's finding (no edit needed) and its edits are not searched;
1. every single edit (:mod:`regen.falsify.space`), spread over the scenarios round-robin;
2. with a model (``llm``): once the singles are done or half the budget is spent, the causes the
   model proposes from the failures so far (:mod:`regen.falsify.proposals`), as ``add`` edits;
3. pairs of compatible singles of one scenario: first those whose two edits each passed alone
   (a combination that fails is new), then those with an invalid one; a pair holding a failing
   single is never tried (it could not be minimal);
4. each failing candidate shrunk to the fewest edits that still fail (:mod:`regen.falsify.shrink`,
   results reused by key, new subsets within the budget);
5. the parameter stage: ``regen.falsify.params.search_parameters`` per minimal finding, when
   that module is installed.

Every candidate is written as it finishes, and ``falsify.json`` after each one; a rerun with the
same settings keeps the finished candidates (:func:`regen.falsify.candidate.kept`) and continues.
A first Ctrl-C lets the current candidate finish, writes ``falsify.json`` and raises
KeyboardInterrupt.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from regen.core.io import try_lock, write_json
from regen.errors import ConfigError, RegenError
from regen.falsify.candidate import Bench, Source, kept, replay_command, run_candidate
from regen.falsify.record import (
    FALSIFY_JSON,
    CandidateRecord,
    Falsification,
    Finding,
    Origin,
)
from regen.falsify.shrink import shrink
from regen.falsify.space import compatible, edit_key, root_causes, single_edits
from regen.runfolder import RunFolder, now, read_graph, read_json
from regen.whatif import Edit

if TYPE_CHECKING:
    from regen.harness.contract import PolicyHarness
    from regen.llm.client import LLM

log = logging.getLogger(__name__)

LOCK = ".lock"
DEFAULT_PARAM_BUDGET = 8  # parameter points per minimal finding
#: settings whose change makes a rerun test its candidates again (the budget only extends a search)
RESULT_SETTINGS = ("policy", "policy_digest", "oracle", "seed")


def default_out(run_dir: str | Path, policy: str) -> Path:
    """RUN/falsify/<policy as a file name> (named as ``regen test`` names its folders)."""
    from regen.harness.cli import default_out as tests_out

    return Path(run_dir) / RunFolder.FALSIFY / tests_out(Path(run_dir), policy).name


def sources_of(rf: RunFolder, domain: str) -> list[Source]:
    """The run's verified scenarios with a readable cause path, ``caused`` ones first (then in run order)."""
    from regen.core.graph import CausePath
    from regen.runfolder import read_model

    found = []
    for name, folder, scenario, verdict in rf.scenarios_of(domain):
        path = read_model(folder / folder.PATH, CausePath)
        if verdict is not None and verdict.feasible and path.ok:
            found.append(Source(name=name, folder=folder.path, scenario=scenario, path=path.value, verdict=verdict))
    return sorted(found, key=lambda s: s.causal != "caused")


def failure_words(rec: CandidateRecord) -> str:
    """How the policy failed, in words: the collision, the missed state, or the incident."""
    p = rec.policy
    if p is None:
        return rec.reason
    if p.collision:
        at = f" at {p.collision_time:.1f} s" if p.collision_time is not None else ""
        return f"collision with {p.collision_with or 'something'}{at}"
    if p.cause == "state_not_reached":
        return f"missed state: {p.missed[0]}" if p.missed else p.message
    what = (p.cause or "failed").replace("_", " ")
    return p.message if p.message.lower().startswith(what) else f"{what}: {p.message}"


def _interleave(lists: Sequence[Sequence[Any]]) -> Iterator[Any]:
    """Round-robin over ``lists``: the first of each, then the second of each, ..."""
    for k in range(max((len(x) for x in lists), default=0)):
        for x in lists:
            if k < len(x):
                yield x[k]


@dataclass
class _Search:
    """One ``regen falsify``: the candidates tried so far, in order, by id."""

    bench: Bench
    sources: list[Source]
    budget: int
    report: Falsification
    llm: LLM | None = None
    on_candidate: Callable[[CandidateRecord, int], None] | None = None
    interrupts: Any = None
    records: dict[str, CandidateRecord] = field(default_factory=dict)
    order: list[str] = field(default_factory=list)
    spent: int = 0  # candidates simulated: what the budget counts
    singles: dict[str, list[tuple[Edit, Origin]]] = field(default_factory=dict)  # per source
    fails_as_generated: set[str] = field(default_factory=set)  # sources the policy fails with no edit
    t0: float = field(default_factory=time.perf_counter)

    # --- candidates ------------------------------------------------------------------------

    def tried(self, source: Source, edits: Sequence[Edit]) -> CandidateRecord | None:
        from regen.falsify.space import candidate_id

        return self.records.get(candidate_id(source.name, edits))

    def attempt(self, source: Source, edits: Sequence[Edit], origin: Origin, by_model: bool = False
                ) -> CandidateRecord | None:
        """The candidate's record: an earlier one of this search, one an earlier run kept, or a
        new run; None once the budget is spent."""
        from regen.falsify.space import candidate_id

        cid = candidate_id(source.name, edits)
        if cid in self.records:
            return self.records[cid]
        if self.spent >= self.budget:
            return None
        with self.interrupts.deferred():  # a first Ctrl-C lets this candidate finish and keeps it
            rec = kept(self.bench, cid)
            if rec is not None:
                rec = rec.model_copy(update={"origin": origin, "by_model": by_model})
            else:
                rec = run_candidate(self.bench, source, edits, origin=origin, by_model=by_model)
        self.records[cid] = rec
        self.order.append(cid)
        self.spent += rec.simulated
        if self.on_candidate is not None:
            self.on_candidate(rec, self.spent)
        self.write()
        self.interrupts.check()
        return rec

    # --- rounds ------------------------------------------------------------------------------

    def plan(self, graph: Any) -> None:
        """Each source's single edits (the graph's other root causes as additions), recorded in
        the report's sources."""
        from regen import domains

        for s in self.sources:
            causes = root_causes(graph, s.path.events)
            own = frozenset(domains.make(s.scenario.domain).own_objects(s.scenario.behavior))
            edits = single_edits(s.scenario, s.path, self.bench.db, causes, robot=self.bench.robot, own=own)
            self.singles[s.name] = [(e, "single") for e in edits]
            self.report.sources.append({"scenario": s.name, "status": s.verdict.status, "causal": s.causal,
                                        "singles": len(edits), "graph_causes": causes})

    def baselines(self) -> None:
        """Each source scenario as generated (no edit) with the policy, before any edit: where
        the policy fails already, that is the finding (its minimal edit set is empty) and the
        source's edits are not searched, since every failing edit of it would be explained by
        the failure without one."""
        for s in self.sources:
            rec = self.attempt(s, [], "baseline")
            if rec is None:
                return
            entry = next(e for e in self.report.sources if e["scenario"] == s.name)
            entry["baseline"] = rec.status
            if rec.status == "failed":
                self.records[rec.cid] = rec.model_copy(update={"minimal": True})
                entry["note"] = (f"the policy fails without any edit ({failure_words(rec)}); its edits are not "
                                 "searched")
                self.singles[s.name] = []
                self.fails_as_generated.add(s.name)

    def run(self) -> None:
        self.baselines()
        order = [[(s, e, o) for e, o in self.singles[s.name]] for s in self.sources]
        asked = self.llm is None
        for source, edit, origin in _interleave(order):
            if not asked and self.spent >= self.budget // 2:
                asked = True
                self.model_round()
            if self.attempt(source, [edit], origin) is None:
                break
        if not asked:
            self.model_round()
        self.pairs()
        self.shrink_all()

    def model_round(self) -> None:
        """Ask the model for causes per source scenario whose edits are searched (not one the
        policy fails as generated); try each as an ``add``. No call once the budget is spent (the
        baselines may spend it all): its causes could not be tried."""
        from regen.falsify.proposals import propose_causes

        if self.spent >= self.budget:
            return
        new: list[list[tuple[Source, Edit]]] = []
        for s in self.sources:
            if s.name in self.fails_as_generated:
                continue
            failures = [f"{'; '.join(r.words)}: {failure_words(r)}" for r in self.of(s) if r.status == "failed"]
            tried = [s.scenario.causal_graph[0], *(e.text or "" for e, _ in self.singles[s.name] if e.op == "add")]
            with self.interrupts.deferred():
                got = propose_causes(s.scenario, s.name, self.llm, self.bench.db, policy=self.bench.policy,
                                     failures=failures, tried=tried, robot=self.bench.robot)
            self.report.model.append(got)
            adds = [Edit(op="add", text=t) for t in got.causes]
            self.singles[s.name] += [(e, "model") for e in adds]
            new.append([(s, e) for e in adds])
            self.interrupts.check()
        for source, edit in _interleave(new):
            if self.attempt(source, [edit], "model", by_model=True) is None:
                return

    def of(self, source: Source) -> list[CandidateRecord]:
        return [self.records[c] for c in self.order if self.records[c].scenario == source.name]

    def pairs(self) -> None:
        """Pairs of compatible singles per source: both passed alone first, then with an invalid
        one; none with a failing (or erroring, or untried) single."""
        ranked: list[list[list[tuple[Source, list[Edit], bool]]]] = [[], []]
        for s in self.sources:
            done = [(e, o, self.tried(s, [e])) for e, o in self.singles[s.name]]
            usable = [(e, o, r) for e, o, r in done if r is not None and r.status in ("passed", "invalid")]
            mine: list[list[tuple[Source, list[Edit], bool]]] = [[], []]
            for (a, oa, ra), (b, ob, rb) in itertools.combinations(usable, 2):
                if compatible(a, b):
                    rank = 0 if ra.status == rb.status == "passed" else 1
                    mine[rank].append((s, [a, b], "model" in (oa, ob)))
            for rank in (0, 1):
                ranked[rank].append(mine[rank])
        for rank in (0, 1):
            for source, edits, by_model in _interleave(ranked[rank]):
                if self.attempt(source, edits, "pair", by_model) is None:
                    return

    def shrink_all(self) -> None:
        """Each failing candidate shrunk to the fewest edits that still fail."""
        for cid in list(self.order):
            rec = self.records[cid]
            if rec.status != "failed":
                continue
            if not rec.edits:  # the baseline: the scenario fails as generated, nothing to shrink
                self.records[cid] = rec.model_copy(update={"minimal": True, "chain": [cid]})
                continue
            source = next(s for s in self.sources if s.name == rec.scenario)
            by_key = {edit_key(e): e for e in rec.edits}
            shrunk = shrink(list(by_key), functools.partial(self.outcome, source, by_key))
            chain = [self.tried(source, [by_key[k] for k in keys]) for keys in shrunk.chain]
            end = chain[-1]
            self.records[cid] = rec.model_copy(update={
                "minimal": shrunk.minimal if end is not None and end.cid == rec.cid else False,
                "chain": [c.cid for c in chain if c is not None]})
            if end is not None and end.cid != rec.cid:
                self.records[end.cid] = self.records[end.cid].model_copy(update={"minimal": shrunk.minimal})
        self.write()

    def outcome(self, source: Source, by_key: dict[str, Edit], keys: tuple[str, ...]) -> str | None:
        """The shrinker's oracle: the status of the candidate made of the edits ``keys`` (run when
        new and the budget allows; None once it is spent)."""
        model = {edit_key(e) for e, o in self.singles[source.name] if o == "model"}
        got = self.attempt(source, [by_key[k] for k in keys], "shrink", bool(set(keys) & model))
        return got.status if got is not None else None

    # --- results -----------------------------------------------------------------------------

    def findings(self) -> list[Finding]:
        """The distinct ends of the failing candidates' shrinking, in the order first found, those
        in which the cause is shown to cause the behavior (``caused``) first."""
        ends: dict[str, list[str]] = {}
        for cid in self.order:
            rec = self.records[cid]
            if rec.status == "failed":  # not shrunk yet (an interrupted search): its own end
                chain = rec.chain or [cid]
                ends.setdefault(chain[-1], chain)
        out = []
        for end, chain in ends.items():
            rec = self.records[end]
            run = self.bench.run_folder(end)
            out.append(Finding(
                cid=end, scenario=rec.scenario, edits=rec.words, edit_list=rec.edits,
                minimal=rec.minimal if rec.minimal is not None else rec.size <= 1,
                chain=[self.records[c].words for c in chain], by_model=rec.by_model, scripted=rec.scripted,
                policy=rec.policy, failure=failure_words(rec), parameters=rec.parameters, folder=str(run),
                gif=self.absolute(rec.policy.gif if rec.policy else None), xosc=self.absolute(rec.xosc),
                tests=self.absolute(rec.tests), replay=replay_command(run, self.bench.policy, self.bench.oracle)))
        return sorted(out, key=lambda f: f.scripted.causal != "caused")

    def absolute(self, rel: str | None) -> str | None:
        return str(self.bench.out / rel) if rel else None

    def write(self, status: str | None = None) -> None:
        r = self.report
        recs = [self.records[c] for c in self.order]
        r.candidates = recs
        r.tried, r.kept, r.simulated = len(recs), sum(x.kept for x in recs), sum(x.simulated for x in recs)
        r.invalid = sum(x.status == "invalid" for x in recs)
        r.errors = sum(x.status == "error" for x in recs)
        r.failures = sum(x.status == "failed" for x in recs)
        r.wall = time.perf_counter() - self.t0
        if status is not None:
            r.status = status  # type: ignore[assignment]
            r.finished = now() if status != "running" else None
        write_json(self.bench.out / FALSIFY_JSON, r)


PARAMETER_JSON = "parameter_search.json"  # in a finding's candidate folder: its search, kept for a rerun


def parameter_stage(findings: list[Finding], harness: PolicyHarness, policy: str, budget: int, seed: int,
                    interrupts: Any, *, oracle: str = "fsm", settings: dict[str, Any] | None = None) -> str:
    """The parameter search per minimal finding (``regen.falsify.params``, written apart); what
    happened, in words, for falsify.json. A finding's search is kept in its candidate folder and
    reused by a rerun with the same settings whose scenario is unchanged."""
    if budget < 1:
        return f"parameter search not run: --param-budget {budget}"
    try:
        from regen.falsify.params import search_parameters
    except ImportError as exc:
        return f"parameter search not run: {exc}"
    from regen.runfolder import ScenarioFolder

    ran = reused = 0
    for f in findings:
        if not f.minimal:
            continue
        folder = Path(f.folder)
        key = {**(settings or {}), "oracle": oracle, "budget": budget, "seed": seed,
               "digest": ScenarioFolder(folder / RunFolder.SCENARIOS / f.cid).digest()}
        earlier = read_json(folder / PARAMETER_JSON).value
        if isinstance(earlier, dict) and earlier.get("key") == key and isinstance(earlier.get("result"), dict):
            f.parameter_search, reused = earlier["result"], reused + 1
            continue
        with interrupts.deferred():
            try:
                got = search_parameters(harness, folder, policy, budget, seed, oracle=oracle)
            except KeyboardInterrupt:
                raise
            except Exception as exc:  # noqa: BLE001 - one finding's search must not lose the others
                log.warning("parameter search of %s failed", f.cid, exc_info=True)
                got = {"error": str(exc) if isinstance(exc, RegenError) else f"{type(exc).__name__}: {exc}"}
        f.parameter_search = dict(got) if isinstance(got, dict) else {"result": got}
        if "error" not in f.parameter_search:
            write_json(folder / PARAMETER_JSON, {"key": key, "result": f.parameter_search})
        ran += 1
        interrupts.check()
    n = ran + reused
    kept = f", {reused} kept from an earlier run" if reused else ""
    return f"parameter search ran for {n} minimal finding{'s' if n != 1 else ''} ({budget} points each{kept})"


def _check_policy(harness: PolicyHarness, policy: str) -> None:
    """ConfigError, before anything is written, when the policy does not load in its process."""
    from regen.harness.process import PolicyProcess

    proc = PolicyProcess(harness, policy)
    try:
        proc.start()
    finally:
        proc.close()


@contextlib.contextmanager
def _locked(out: Path, run: Path) -> Iterator[None]:
    """OUT held by this process, and the run read under a shared lock (regen generate cannot
    write it meanwhile)."""
    fd, other = try_lock(out / LOCK)
    if fd is None:
        raise ConfigError(f"another regen falsify (pid {other}) is writing {out}; wait for it or give "
                          "another --out")
    run_fd = None
    try:
        try:
            run_fd, writer = try_lock(run / RunFolder.LOCK, shared=True)
        except OSError:  # a read-only run: nothing can be writing it
            run_fd, writer = None, ""
        if run_fd is None and writer:
            raise ConfigError(f"regen generate (pid {writer}) is still writing {run}; wait for it to finish, "
                              "then run regen falsify")
        yield
    finally:
        for d in (fd, run_fd):
            if d is not None:
                with contextlib.suppress(OSError):
                    os.close(d)


def run_falsify(run_dir: str | Path, policy: str, *, budget: int, out: str | Path | None = None,
                llm: LLM | None = None, seed: int = 0, oracle: str = "fsm", pictures: bool = True,
                param_budget: int = DEFAULT_PARAM_BUDGET,
                on_candidate: Callable[[CandidateRecord, int], None] | None = None,
                on_note: Callable[[str], None] | None = None,
                make_llm: Callable[[Path], LLM] | None = None) -> Falsification:
    """Search the causes of a run's verified scenarios for what makes ``policy`` fail (see the
    module docstring): at most ``budget`` candidates, written under ``out`` (default
    RUN/falsify/<policy>), ``falsify.json`` last. ``llm``: a model that proposes causes (None: no
    model call). ``seed``: added to each scenario's grounding seed, and the tests' seed.
    ``on_candidate(record, n)`` hears each candidate as it finishes. ``make_llm(out)``: makes
    the model once the folder is checked (its cache goes there), when ``llm`` is None. ConfigError
    for a bad folder, policy, budget or oracle."""
    from regen.harness.oracle import ORACLES
    from regen.harness.suite import open_suite
    from regen.interrupts import Interrupts
    from regen.promises.folders import output_folder

    if budget < 1:
        raise ConfigError(f"--budget must be at least 1 (got {budget}): the number of candidates to ground, "
                          "simulate and test")
    if oracle not in ORACLES:
        raise ConfigError(f"unknown oracle {oracle!r}; choose one of: {', '.join(ORACLES)}")
    rf, domain, harness = open_suite(Path(run_dir).absolute())
    sources = sources_of(rf, domain)
    if not sources:
        raise ConfigError(f"{rf.path} has no verified scenario to start from (see its report.html); "
                          "regen falsify edits the causes of verified scenarios")
    _check_policy(harness, policy)
    dest = Path(out if out is not None else default_out(rf.path, policy)).absolute()
    output_folder(dest, given=out is not None, give="a folder for falsify.json and the candidates")
    bench = _bench(rf, domain, harness, dest, policy, oracle=oracle, seed=seed, pictures=pictures, on_note=on_note)
    if llm is None and make_llm is not None:
        llm = make_llm(dest)
    with _locked(dest, rf.path):
        _note_changed(dest, bench.settings, on_note)
        report = Falsification(run=str(rf.path), out=str(dest), domain=domain, robot=harness.robot, policy=policy,
                               budget=budget, started=now(),
                               settings={**bench.settings, "llm": llm.provider.id if llm is not None else None,
                                         "pictures": pictures, "param_budget": param_budget})
        with Interrupts() as interrupts:
            search = _Search(bench=bench, sources=sources, budget=budget, report=report, llm=llm,
                             on_candidate=on_candidate, interrupts=interrupts)
            search.plan(read_graph(rf.path).value)
            try:
                search.run()
                report.findings = search.findings()
                report.timings["search"] = time.perf_counter() - search.t0
                search.write()
                t0 = time.perf_counter()
                report.parameter_search = parameter_stage(report.findings, harness, policy, param_budget, seed,
                                                          interrupts, oracle=oracle, settings=bench.settings)
                report.timings["parameters"] = time.perf_counter() - t0
            except KeyboardInterrupt:
                report.findings = report.findings or search.findings()
                search.write("interrupted")
                raise
            search.write("done")
    return report


def _bench(rf: RunFolder, domain: str, harness: PolicyHarness, dest: Path, policy: str, *, oracle: str,
           seed: int, pictures: bool, on_note: Callable[[str], None] | None) -> Bench:
    """What every candidate of the search shares, with the run's domain settings for their run.json."""
    from regen import domains
    from regen.harness.results import policy_digest

    backend = domains.make(domain)
    settings = {"policy": policy, "policy_digest": policy_digest(policy), "oracle": oracle, "seed": seed}
    bench = Bench(out=dest, harness=harness, db=backend.database(),
                  robot=(backend.report_hints.robot, *backend.wording.robot_names), policy=policy, oracle=oracle,
                  seed=seed, pictures=pictures, settings=settings, on_note=on_note)
    manifest = rf.read_manifest_raw().value
    if isinstance(manifest, dict) and isinstance(manifest.get("domain_settings"), dict):
        bench.domain_settings = {str(k): v for k, v in manifest["domain_settings"].items()
                                 if v is None or isinstance(v, str)}
    return bench


def _note_changed(dest: Path, settings: dict[str, Any], on_note: Callable[[str], None] | None) -> None:
    """Tell when an earlier search in ``dest`` was made with other result settings."""
    earlier = read_json(dest / FALSIFY_JSON).value
    old = earlier.get("settings") if isinstance(earlier, dict) else None
    if isinstance(old, dict) and on_note is not None and any(old.get(k) != settings[k] for k in RESULT_SETTINGS):
        changed = ", ".join("the policy file" if k == "policy_digest" else k
                            for k in RESULT_SETTINGS if old.get(k) != settings[k])
        on_note(f"{dest}: {changed} changed since its last run; its candidates are tested again")

__all__ = ["DEFAULT_PARAM_BUDGET", "default_out", "failure_words", "parameter_stage", "run_falsify", "sources_of"]
