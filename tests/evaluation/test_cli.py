"""`regen eval` through typer's runner, and evaluate() end to end."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from regen.core.io import write_json
from regen.evaluation.cli import make_app
from regen.evaluation.evaluate import EvalSettings, evaluate

runner = CliRunner()


@pytest.fixture
def text_files(tmp_path):
    a = tmp_path / "alike.txt"
    a.write_text("\n".join(f"the ego vehicle stops because a pedestrian crosses {i}"
                           for i in range(8)))
    b = tmp_path / "varied.json"
    b.write_text(json.dumps(["an ambulance approaches from behind with its siren on",
                             "debris falls off a truck onto the highway",
                             "the traffic light at the junction turns red",
                             "a cyclist cuts in from the adjacent lane",
                             "sun glare blinds the front camera at dawn",
                             "a child runs after a ball between parked cars"]))
    return a, b


@pytest.fixture
def run_dir(tmp_path, scenario_factory, verdict_factory):
    run = tmp_path / "run"
    write_json(run / "run.json", {"behavior": "the ego-vehicle stops abruptly"})
    items = [("s1", "ambulance behind", "An ambulance approaches from behind, siren on.", True),
             ("s2", "ambulance behind", "An ambulance approaches in the left lane, siren on.", False),
             ("s3", "jaywalker", "A jaywalker crosses between parked cars.", True)]
    for sid, cause, text, ok in items:
        write_json(run / "scenarios" / sid / "scenario.json", scenario_factory(sid, [cause], text))
        write_json(run / "scenarios" / sid / "verdict.json", verdict_factory(ok))
    return run


def test_cli_text_sets_without_embeddings(text_files, tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(make_app(), ["eval", *map(str, text_files), "--no-embeddings",
                                     "--repeats", "3", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "Self-BLEU diversity" in res.output
    data = json.loads((out / "eval.json").read_text())
    by = {d["name"]: d for d in data["diversity"]}
    assert by["alike"]["sample_size"] == 6 and by["alike"]["repeats"] == 3
    assert by["alike"]["embedding_diversity"] is None
    assert by["varied"]["self_bleu_diversity"]["mean"] > by["alike"]["self_bleu_diversity"]["mean"]
    assert (out / "diversity.png").stat().st_size > 1000


def test_cli_full_with_run_folder(encoder, text_files, run_dir, tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(make_app(), ["eval", str(run_dir), "example:zero_shot_style",
                                     str(text_files[1]), "--out", str(out), "--seed", "1"],
                        terminal_width=200)
    assert res.exit_code == 0, res.output
    assert "embedding diversity" in res.output and "Self-BLEU diversity" in res.output
    assert "Feasibility per behavior" in res.output and "Controllability" in res.output
    for name in ("diversity.png", "feasibility.png", "controllability.png", "eval.json"):
        assert (out / name).is_file(), name
    data = json.loads((out / "eval.json").read_text())
    assert data["feasibility"]["total"]["feasible"] == 2
    assert data["controllability"]["groups"]["same cause, different properties"]["pairs"] == 1
    assert all(d["sample_size"] == 3 for d in data["diversity"])  # the run has 3 scenarios


def test_cli_reports_bad_input_without_traceback(tmp_path):
    res = runner.invoke(make_app(), ["eval", str(tmp_path / "missing.txt"), "--no-embeddings"])
    assert res.exit_code == 2
    assert "does not exist" in res.output
    assert "Traceback" not in res.output
    res = runner.invoke(make_app(), ["eval"])
    assert res.exit_code == 2 and "nothing to evaluate" in res.output


def test_cli_lists_examples():
    res = runner.invoke(make_app(), ["eval", "--list-examples"])
    assert res.exit_code == 0 and "example:nhtsa_style" in res.output


def test_evaluate_edges_and_small_sets(tmp_path, fake_encoder):
    edges = tmp_path / "e.jsonl"
    edges.write_text(json.dumps({"kind": "entity->event", "source": "ambulance behind",
                                 "candidate": "ambulance", "label": True, "domain": "driving"}) + "\n")
    one = tmp_path / "one.txt"
    one.write_text("just one line\n")
    rep = evaluate([one], edges_file=edges, judge=lambda k, s, c, **kw: set(c),
                   settings=EvalSettings(edge_trials=2), encoder=fake_encoder,
                   out_dir=tmp_path / "out")
    assert "one" in rep.skipped and rep.diversity == []
    assert rep.edges.groups[0].accuracy.mean == 1.0
    assert (tmp_path / "out" / "edges.png").is_file()
