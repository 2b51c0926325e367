"""The batch summary and report over a batch folder built by hand from the real formats: run.json
(RunManifest), verdict.json (Verdict with its causal part), scenario.json, tests.json
(SuiteReport), and batch.json as the runner writes it. The batch is half done on purpose: one
behavior finished, one failed with a lost scenario, one never started."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "report"))  # the report tests' builders
from report_runs import HOSTILE, incomplete, make_scenario, verified  # noqa: E402

from regen.batch import diversity as batch_diversity  # noqa: E402
from regen.batch.summary import (  # noqa: E402
    BatchSummary,
    summarize_batch,
    verdict_bar,
    write_batch_report,
)
from regen.core.behavior import Behavior  # noqa: E402
from regen.core.io import write_json  # noqa: E402
from regen.core.verdict import Causal, Verdict  # noqa: E402
from regen.errors import ConfigError  # noqa: E402
from regen.harness.cases import CaseResult, SuiteReport  # noqa: E402
from regen.runfolder import RunManifest, RunSettings  # noqa: E402

STOP = "the ego-vehicle stops abruptly"
SLOW = f"the ego-vehicle slows down {HOSTILE}"
DOOR = "the robot opens the door"
LOST_REASON = "the worker died twice: killed by signal 9 <b>twice</b>"


class WordEncoder:
    """Test double of the sentence encoder: one axis per distinct word, so texts sharing no
    word are orthogonal (embedding diversity 1) and equal texts coincide (0)."""

    def __init__(self):
        self.seen: list[list[str]] = []

    def encode(self, texts):
        self.seen.append(list(texts))
        words = sorted({w for t in texts for w in re.findall(r"\w+", t.lower())})
        out = np.zeros((len(texts), len(words)))
        for i, t in enumerate(texts):
            for w in re.findall(r"\w+", t.lower()):
                out[i, words.index(w)] = 1.0
        return out


def _with_causal(verdict: Verdict, status: str, confounders: list[str] | None = None) -> Verdict:
    return verdict.model_copy(update={"causal": Causal(status=status, reason=f"reference: {status}",
                                                       confounders=confounders or [])})


def make_run(run: Path, text: str, scenarios: list[tuple[str, str, Verdict | None]], *,
             status: str = "done", finished: bool = True, tests: list[CaseResult] | None = None) -> None:
    """A run folder as ``regen generate`` leaves it: (folder, narrative, verdict or None) each;
    ``finished`` adds summary.json and report.html."""
    behavior = Behavior(text=text, domain="driving", params={"ego_template": "stop_abruptly"})
    for i, (folder, narrative, verdict) in enumerate(scenarios, start=1):
        d = run / "scenarios" / folder
        d.mkdir(parents=True)
        write_json(d / "scenario.json", {"scenario": make_scenario(i, narrative=narrative, behavior_text=text)
                                         .model_dump(mode="json"), "config": {}})
        if verdict is not None:
            write_json(d / "verdict.json", verdict)
    usage = {"total": {"calls": 9, "model_calls": 7, "cache_hits": 2, "reasks": 0, "failures": 0,
                       "input_tokens": 4000, "output_tokens": 700, "latency": 50.0}, "by_purpose": {}}
    write_json(run / "run.json", RunManifest(
        behavior=behavior, settings=RunSettings(), status=status, started="2025-01-02T10:00:00+00:00",
        timings={"expand": 10.0, "ground": 2.5, "simulate": 30.0}, usage=usage,
        scenarios=[s[0] for s in scenarios]))
    if finished:
        write_json(run / "summary.json", {"behavior": text, "domain": "driving", "status": status,
                                          "scenarios": len(scenarios)})
        (run / "report.html").write_text("<!DOCTYPE html><title>run</title>")
    if tests is not None:
        write_json(run / "tests" / "idm" / "tests.json", SuiteReport(run=str(run), policy="idm", cases=tests))


def _entry(folder: str, text: str, domain: str, status: str, **more: Any) -> dict[str, Any]:
    return {"folder": folder, "text": text, "domain": domain, "scenarios": 3, "status": status,
            "message": "", "failed_scenarios": {}, "wall_seconds": None, **more}


def build_batch(root: Path) -> Path:
    """``root/batch`` with three behaviors: done (3 verdicts, policy tests), failed (one
    scenario lost), pending."""
    d = root / "batch"
    make_run(d / "01-the-ego-vehicle-stops-abruptly", STOP, [
        ("01-a-child-runs-out", "A child runs out between parked cars.", _with_causal(verified(), "caused")),
        ("02-a-light-turns-red", "The traffic light ahead turns red.",
         _with_causal(verified(), "confounded", ["traffic_light1"])),
        ("03-a-cyclist-swerves", "A cyclist swerves into the lane.", _with_causal(incomplete(), "caused")),
    ], tests=[CaseResult(scenario="01-a-child-runs-out", status="failed", cause="collision", collision=True),
              CaseResult(scenario="02-a-light-turns-red", status="passed")])
    make_run(d / "02-the-ego-vehicle-slows-down", SLOW, [
        ("01-fog-rolls-in", f"Dense fog rolls in. {HOSTILE}", verified()),
        ("02-a-deer-crosses", "A deer crosses.", None),
    ], status="failed", finished=False)
    write_json(d / "batch.json", {
        "version": 1, "spec_file": "examples/batch.yaml", "spec_sha256": "0" * 64, "executor": "pool",
        "workers": 2, "ray_address": None, "started": "2025-01-02T10:00:00+00:00", "finished": None,
        "status": "failed", "message": "1 behavior failed", "wall_seconds": 123.4,
        "behaviors": [
            _entry("01-the-ego-vehicle-stops-abruptly", STOP, "driving", "done", wall_seconds=60.0),
            _entry("02-the-ego-vehicle-slows-down", SLOW, "driving", "failed",
                   message=f"the provider did not answer {HOSTILE}", wall_seconds=20.0,
                   failed_scenarios={"02-a-deer-crosses": LOST_REASON}),
            _entry("03-the-robot-opens-the-door", DOOR, "manipulation", "pending", scenarios=2),
        ]})
    return d


@pytest.fixture
def batch(tmp_path: Path) -> Path:
    return build_batch(tmp_path)


def _by_folder(summary: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {b["folder"][:2]: b for b in summary["behaviors"]}


def test_counts_come_from_the_verdicts(batch):
    summary = summarize_batch(batch, encoder=WordEncoder())
    assert json.loads((batch / "summary.json").read_text()) == summary
    done = _by_folder(summary)["01"]
    assert done["status"] == "done" and done["run_status"] == "done"
    assert done["statuses"] == {"verified": 2, "fsm_incomplete": 1}
    assert (done["finished"], done["verified"], done["feasible"]) == (3, 2, 2)
    assert done["caused"] == 1  # neither the confounded one nor the caused but infeasible one
    assert done["causal"] == {"caused": 2, "confounded": 1}
    assert done["timings"] == {"expand": 10.0, "ground": 2.5, "simulate": 30.0}
    assert done["usage"]["calls"] == 9 and done["usage"]["output_tokens"] == 700
    assert done["missing"] == [] and done["report"] == "01-the-ego-vehicle-stops-abruptly/report.html"
    totals = summary["totals"]
    assert (totals["finished"], totals["feasible"], totals["caused"]) == (4, 3, 1)
    assert totals["by_status"] == {"done": 1, "failed": 1, "pending": 1}
    assert totals["timings"]["simulate"] == 60.0 and totals["usage"]["calls"] == 18
    assert totals["failed_scenarios"] == 1


def test_a_failed_and_a_pending_behavior_say_what_is_missing(batch):
    summary = _by_folder(summarize_batch(batch, encoder=WordEncoder()))
    failed = summary["02"]
    assert failed["status"] == "failed" and "did not answer" in failed["message"]
    assert failed["failed_scenarios"] == [{"folder": "02-a-deer-crosses", "reason": LOST_REASON}]
    assert failed["lost"] == 1 and failed["unfinished"] == []  # lost, not merely unfinished
    assert failed["report"] is None
    assert any("summary.json: missing" in m for m in failed["missing"])
    assert any("report.html: missing" in m for m in failed["missing"])
    pending = summary["03"]
    assert pending["missing"] == ["run folder: not started"]
    assert pending["not_started"] == 2 and pending["finished"] == 0
    assert [(s.status, s.count) for s in verdict_bar(BatchSummary.model_validate(
        {"behaviors": [failed]}).behaviors[0])] == [("verified", 1), ("failed", 1)]


def test_policy_tests_give_collision_rates_and_none_says_so(batch):
    summary = _by_folder(summarize_batch(batch, encoder=WordEncoder()))
    (idm,) = summary["01"]["tests"]
    assert (idm["policy"], idm["tests"], idm["collisions"], idm["collision_rate"]) == ("idm", 2, 1, 0.5)
    assert summary["02"]["tests"] == []
    page = write_batch_report(batch).read_text()
    rows = re.findall(r'<tr class="no-tests">.*?</tr>', page, re.S)
    assert len(rows) == 2 and all("no tests ran" in r for r in rows)
    assert "50 %" in page


def test_diversity_over_the_feasible_scenarios(batch):
    enc = WordEncoder()
    div = summarize_batch(batch, encoder=enc)["diversity"]
    texts = enc.seen[0]
    assert sorted(texts) == sorted(["A child runs out between parked cars.", "The traffic light ahead turns red.",
                                    f"Dense fog rolls in. {HOSTILE}"])  # the fsm_incomplete one is left out
    (fig,) = div["figures"]  # one domain has feasible scenarios: only 'all'
    assert fig["scope"] == "all" and fig["texts"] == 3
    # 7, 6 and 11 distinct words; only the child's and the fog's texts share one ('a'): of the
    # three pairs one has cosine 1/sqrt(7 * 11), the others 0
    assert fig["embedding"] == pytest.approx(1.0 - 1.0 / np.sqrt(7 * 11) / 3, abs=1e-12)
    assert "embedding" in div["computed"]

    div = summarize_batch(batch, embeddings=False)["diversity"]
    assert div["computed"] == ["self_bleu"]  # Self-BLEU needs no optional package
    assert div["skipped"] == {"embedding": "turned off"}
    page = write_batch_report(batch, summarize_batch(batch, embeddings=False)).read_text()
    assert "Computed: Self-BLEU diversity." in page and "turned off" in page


def test_self_bleu_is_computed_with_the_embeddings(batch):
    div = summarize_batch(batch, encoder=WordEncoder())["diversity"]
    assert div["computed"] == ["embedding", "self_bleu"]
    assert 0.0 < div["figures"][0]["self_bleu"] <= 1.0


def test_report_links_each_run_and_escapes_model_text(batch):
    path = write_batch_report(batch, summarize_batch(batch, encoder=WordEncoder()))
    assert path == batch / "report.html"
    page = path.read_text()
    assert 'href="01-the-ego-vehicle-stops-abruptly/report.html"' in page
    assert "02-the-ego-vehicle-slows-down/report.html" not in page  # no report there yet
    assert 'href="batch.json"' in page and 'href="summary.json"' in page
    assert "<script>alert(1)" not in page and "<b>bold</b>" not in page and "<b>twice</b>" not in page
    assert "&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "killed by signal 9 &lt;b&gt;twice&lt;/b&gt;" in page  # the lost scenario with its reason
    assert "run folder: not started" in page and "summary.json: missing" in page
    assert not re.search(r"<script|https?://", page)  # offline, no scripts
    bar = re.search(r'<tr class="behavior-row" id="behavior-1">.*?</tr>', page, re.S).group(0)
    assert re.findall(r'class="seg-(\w+)" style="width: ([\d.]+)%"', bar) == [
        ("verified", "66.67"), ("fsm_incomplete", "33.33")]


def test_without_batch_json_the_run_folders_are_found(batch):
    (batch / "batch.json").unlink()
    summary = summarize_batch(batch, embeddings=False)
    assert summary["problems"] == ["batch.json: missing"]
    assert [b["folder"] for b in summary["behaviors"]] == ["01-the-ego-vehicle-stops-abruptly",
                                                           "02-the-ego-vehicle-slows-down"]
    assert summary["behaviors"][1]["text"] == SLOW  # from run.json
    assert "batch.json: missing" in write_batch_report(batch).read_text()


def test_a_folder_outside_the_batch_is_never_read(batch, tmp_path):
    data = json.loads((batch / "batch.json").read_text())
    data["behaviors"].append(_entry("../elsewhere", "x", "driving", "done"))
    make_run(tmp_path / "elsewhere", "x", [("01-x", "x", verified())])
    (batch / "batch.json").write_text(json.dumps(data))
    summary = summarize_batch(batch, embeddings=False)
    assert len(summary["behaviors"]) == 3
    assert any("without a usable folder name" in p for p in summary["problems"])


def test_a_broken_run_json_is_named(batch):
    (batch / "01-the-ego-vehicle-stops-abruptly" / "run.json").write_text("{not json")
    done = _by_folder(summarize_batch(batch, embeddings=False))["01"]
    assert any(m.startswith("run.json: unreadable") for m in done["missing"])
    assert done["feasible"] == 2  # the verdicts still count


def test_not_a_folder_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="no batch folder"):
        summarize_batch(tmp_path / "nope")
    with pytest.raises(ConfigError, match="no batch folder"):
        write_batch_report(tmp_path / "nope")


def test_diversity_per_domain_when_several_domains_have_texts(monkeypatch):
    monkeypatch.setattr(batch_diversity, "self_bleu_diversity", lambda texts: float(len(texts)))
    enc = WordEncoder()
    div = batch_diversity.batch_diversity(
        {"driving": ["a red car brakes", "a child runs out"], "manipulation": ["the cat sleeps"]}, encoder=enc)
    assert [(f.scope, f.texts, f.self_bleu) for f in div.figures] == [("all", 3, 3.0), ("driving", 2, 2.0)]
    assert "diversity needs at least two" in div.skipped["manipulation"]
    assert div.computed == ["embedding", "self_bleu"]


def test_a_large_set_is_sampled_the_same_way_each_time(monkeypatch):
    monkeypatch.setattr(batch_diversity, "self_bleu_diversity", lambda texts: float(len(texts)))
    texts = {"driving": [f"cause number {i}" for i in range(250)]}
    enc = WordEncoder()
    (fig,) = batch_diversity.batch_diversity(texts, encoder=enc).figures
    assert fig.texts == 250 and fig.self_bleu == batch_diversity.MAX_DIVERSITY_TEXTS
    again = WordEncoder()
    batch_diversity.batch_diversity(texts, encoder=again)
    assert len(enc.seen[0]) == batch_diversity.MAX_DIVERSITY_TEXTS and enc.seen == again.seen


def test_the_report_alone_summarizes_first(batch):
    write_batch_report(batch)
    summary = json.loads((batch / "summary.json").read_text())
    assert summary["totals"]["feasible"] == 3
    assert 'href="summary.json"' in (batch / "report.html").read_text()
