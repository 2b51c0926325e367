"""``regen probe``: a model's answers to a dataset's questions scored by exact match against the
keys, per layer, behavior and cause; the planning confusion matrix; the counterfactual flips;
pictures sent as PNG data URLs (seen by the loopback server); the text-only offline model asked
with the privileged information; bad input refused in one line. Every model here is a fake."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import pytest
from fault_server import FaultServer, answer
from PIL import Image
from typer.testing import CliRunner

from regen.cli import app
from regen.dataset.labels import LABELS
from regen.dataset.probe import TEXT_ONLY_NOTE, probe_dataset
from regen.dataset.probe_score import CONFUSION, PROBE_JSON, REPORT
from regen.dataset.qa import COMES, DIRECTIONS, MOTIONS, MOVES_ON
from regen.llm import registry
from regen.llm.providers.openai_compat import OpenAIProvider
from regen.llm.testing import FunctionProvider

pa = pytest.importorskip("pyarrow", reason="the 'dataset' extra is not installed")
pq = pytest.importorskip("pyarrow.parquet")

ACTIONS = list(LABELS)
# sample id -> (pair id, planning key, counterfactual key, behavior, the cause's asset)
SAMPLES = {
    "s1": ("p1", "stop", "keep_speed", "the ego-vehicle stops", "sedan"),
    "s2": ("p1", "stop", "keep_speed", "the ego-vehicle stops", "sedan"),
    "s3": ("p3", "slow_down", "keep_speed", "the ego-vehicle slows down", "adult"),
    "s4": ("p4", "accelerate", "stop", "the ego-vehicle drives off", "traffic_light"),
}


def _frame(sid: str, asset: str, t: float) -> dict:
    ent = {"kind": "agent", "x": 20.0 + t, "y": 0.0, "heading": 0.0, "speed": 8.0, "length": 4.6, "width": 1.9,
           "height": 1.5, "states": [{"key": "light_state", "value": "red"}, {"key": "lane", "value": None}]}
    return {"t": t, "step": int(t * 10), "entities": [
        {**ent, "name": "ego", "kind": "ego", "asset": "ego", "x": 10.0 * t, "states": []},
        {**ent, "name": f"{sid}_cause", "asset": asset}]}


def write_dataset(folder: Path, samples: dict = SAMPLES) -> Path:
    """A dataset folder as regen dataset writes it: per sample three bird's-eye PNGs, four
    scored questions (one a layer) and the unscored overview."""
    rows, qa = [], []
    for n, (sid, (pair, action, cf, behavior, asset)) in enumerate(sorted(samples.items())):
        times = [4.0, 4.5, 5.0]
        row = {"sample_id": sid, "pair_id": pair, "source": "scenario", "behavior": behavior, "action": action,
               "frame_times": times, "cause_entities": [f"{sid}_cause"],
               "privileged": [_frame(sid, asset, t) for t in times]}
        for k in range(3):
            rel = f"images/{sid}/bev_{k}.png"
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            Image.new("RGB", (8, 8), (30 * n, 10 * k, 90)).save(folder / rel)
            row[f"bev_image_{k}"], row[f"camera_image_{k}"] = rel, None
        rows.append(row)
        questions = [("perception", "Which road users and objects are around the ego at t = 5.0 s?", [], None),
                     ("perception", f"Where is {sid}_cause ({asset}) relative to the ego at t = 5.0 s, and in what "
                                    "state?", list(DIRECTIONS), "ahead"),
                     ("prediction", f"What does {sid}_cause ({asset}) do in the next 3 s?", list(MOTIONS),
                      MOVES_ON if n % 2 else COMES),
                     ("planning", "What should the ego do now, and why?", ACTIONS, action),
                     ("counterfactual", f"What would the ego do if {sid}_cause were not there?", ACTIONS, cf)]
        qa += [{"qa_id": f"{sid}-{k:02d}", "sample_id": sid, "pair_id": pair, "layer": layer, "question": q,
                "answer": str(key), "computed_from": "trace", "options": opts, "key": key}
               for k, (layer, q, opts, key) in enumerate(questions)]
    pq.write_table(pa.Table.from_pylist(rows), folder / "samples.parquet")
    pq.write_table(pa.Table.from_pylist(qa), folder / "qa.parquet")
    return folder


def _asked(messages) -> tuple[str, str]:
    """(sample id, question) of a probe prompt: the sample from its cause entity's name."""
    text = messages[-1]["content"]
    return re.search(r"\b(s\d)_cause\b", text).group(1), re.search(r"^Question: (.*)$", text, re.M).group(1)


def keyed(folder: Path) -> FunctionProvider:
    """A fake that answers each question with its key."""
    table = pq.read_table(folder / "qa.parquet").to_pylist()
    keys = {(r["sample_id"], r["question"]): r["key"] for r in table}
    return FunctionProvider(lambda m: {"answer": keys[_asked(m)]})


def always(word: str) -> FunctionProvider:
    return FunctionProvider(lambda m: {"answer": word})


def _doc(out: Path) -> dict:
    return json.loads((out / PROBE_JSON).read_text())


def test_a_model_that_answers_the_keys_scores_one_in_every_layer(tmp_path: Path) -> None:
    ds = write_dataset(tmp_path / "ds")
    res = probe_dataset(ds, keyed(ds), out=tmp_path / "probe")
    sc = res.score
    assert {k: (t.asked, t.accuracy) for k, t in sc.by_layer.items()} == {
        "perception": (4, 1.0), "prediction": (4, 1.0), "planning": (4, 1.0), "counterfactual": (4, 1.0)}
    assert (sc.overall.asked, sc.overall.accuracy, sc.unscored, sc.no_answer) == (16, 1.0, 4, 0)
    assert sc.confusion.counts == [[1, 0, 0], [0, 1, 0], [0, 0, 2]]  # accelerate, slow_down, stop
    doc = _doc(tmp_path / "probe")
    row = next(q for q in doc["questions"] if q["qa_id"] == "s3-03")
    assert row == {"qa_id": "s3-03", "sample_id": "s3", "layer": "planning", "asked": "text", "privileged": True,
                   "answer": "slow_down", "key": "slow_down", "correct": True}
    overview = next(q for q in doc["questions"] if q["qa_id"] == "s3-00")
    assert overview["key"] is None and overview["asked"] is None and overview["correct"] is None
    assert {CONFUSION, "llm-cache.sqlite", PROBE_JSON, REPORT} <= {p.name for p in (tmp_path / "probe").iterdir()}


def test_a_model_that_always_says_stop_gets_the_known_figures(tmp_path: Path) -> None:
    ds = write_dataset(tmp_path / "ds")
    res = probe_dataset(ds, always("stop"), out=tmp_path / "probe")
    sc = res.score
    # planning: s1 and s2 stop; counterfactual: only s4's key is stop; 'stop' is no option of the others
    assert {k: (t.asked, t.correct) for k, t in sc.by_layer.items()} == {
        "perception": (4, 0), "prediction": (4, 0), "planning": (4, 2), "counterfactual": (4, 1)}
    assert (sc.overall.correct, sc.overall.asked, sc.unscored, sc.no_answer) == (3, 16, 4, 8)
    assert {k: t.correct for k, t in sc.by_behavior.items()} == {
        "the ego-vehicle drives off": 1, "the ego-vehicle slows down": 0, "the ego-vehicle stops": 2}
    assert {k: (t.asked, t.correct) for k, t in sc.by_cause.items()} == {
        "pedestrians": (4, 0), "traffic": (4, 1), "vehicles": (8, 2)}
    assert (sc.confusion.truth, sc.confusion.answers) == (["accelerate", "slow_down", "stop"],
                                                          ["accelerate", "slow_down", "stop"])
    assert sc.confusion.counts == [[0, 0, 1], [0, 0, 1], [0, 0, 2]]
    doc = _doc(tmp_path / "probe")
    assert doc["summary"]["by_layer"]["planning"] == {"asked": 4, "correct": 2, "accuracy": 0.5}
    assert doc["summary"]["confusion_planning"]["counts"] == [[0, 0, 1], [0, 0, 1], [0, 0, 2]]
    assert next(q for q in doc["questions"] if q["qa_id"] == "s1-01")["answer"] is None  # no valid option
    assert (tmp_path / "probe" / CONFUSION).read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    assert "| layer: planning | 4 | 2 | 50% |" in (tmp_path / "probe" / REPORT).read_text()


@pytest.mark.parametrize(("s2_key", "model", "expected"), [
    ("keep_speed", "keyed", {"correct": 1, "wrong": 0, "missed": 0, "kept": 0}),  # should flip, flips
    ("keep_speed", "stop", {"correct": 0, "wrong": 0, "missed": 1, "kept": 0}),  # should flip, does not
    ("stop", "flips", {"correct": 0, "wrong": 1, "missed": 0, "kept": 0}),  # should not flip, flips
    ("stop", "stop", {"correct": 0, "wrong": 0, "missed": 0, "kept": 1}),
])
def test_flips_of_a_pair(tmp_path: Path, s2_key: str, model: str, expected: dict) -> None:
    pair = {"s1": ("p1", "stop", "keep_speed", "stops", "sedan"), "s2": ("p1", s2_key, "keep_speed", "stops", "sedan"),
            "s3": ("p3", "stop", "keep_speed", "stops", "adult")}  # alone in its pair: no flip to count
    ds = write_dataset(tmp_path / "ds", pair)
    fakes = {"keyed": keyed(ds), "stop": always("stop"),
             "flips": FunctionProvider(lambda m: {"answer": "stop" if _asked(m)[0] == "s1" else "yield"})}
    flips = probe_dataset(ds, fakes[model], out=tmp_path / "probe", layers="planning").score.flips
    assert flips.pairs == 1
    assert {k: getattr(flips, k) for k in expected} == expected
    assert _doc(tmp_path / "probe")["summary"]["flips"]["pairs"] == 1


def _openai(fault_server: FaultServer) -> OpenAIProvider:
    return OpenAIProvider("vision-model", base_url=fault_server.openai_url, api_key="k", base_delay=0.01)


def test_pictures_go_to_an_image_provider_as_png_data_urls(tmp_path: Path, fault_server: FaultServer) -> None:
    ds = write_dataset(tmp_path / "ds", {"s1": SAMPLES["s1"]})
    fault_server.queue(answer('{"answer": "stop"}'))
    res = probe_dataset(ds, _openai(fault_server), out=tmp_path / "probe", layers="planning")
    assert res.score.overall.correct == 1 and res.mode.images and not res.mode.privileged
    [request] = fault_server.requests
    parts = request.body["messages"][1]["content"]
    assert [p["type"] for p in parts] == ["text", "image_url", "image_url", "image_url"]
    urls = [p["image_url"]["url"] for p in parts[1:]]
    assert all(u.startswith("data:image/png;base64,") for u in urls)
    assert [base64.b64decode(u.partition(",")[2]) for u in urls] == \
        [(ds / f"images/s1/bev_{k}.png").read_bytes() for k in range(3)]
    assert "The 3 pictures are the scene at t = 4.0, 4.5, 5.0 s" in parts[0]["text"]
    assert "s1_cause (agent sedan): x" not in parts[0]["text"]  # no privileged text unless asked
    assert _doc(tmp_path / "probe")["questions"][0]["asked"] == "images"


def test_text_only_sends_no_picture(tmp_path: Path, fault_server: FaultServer) -> None:
    ds = write_dataset(tmp_path / "ds", {"s1": SAMPLES["s1"]})
    fault_server.queue(answer('{"answer": "stop"}'))
    res = probe_dataset(ds, _openai(fault_server), out=tmp_path / "probe", layers="planning", text_only=True)
    assert not res.mode.images and res.mode.privileged
    [request] = fault_server.requests
    content = request.body["messages"][1]["content"]
    assert isinstance(content, str) and "image_url" not in json.dumps(request.body)
    assert "s1_cause (agent sedan): x 25.0, y 0.0, heading 0.00, speed 8.0, 4.6 x 1.9; light_state red" in content
    assert _doc(tmp_path / "probe")["questions"][0]["asked"] == "text"


class FakeLocal(FunctionProvider):
    """Stands in for the offline model: named 'local', reads text only."""

    name = "local"


def test_the_local_model_is_asked_in_text_with_the_privileged_information(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ds = write_dataset(tmp_path / "ds", {"s1": SAMPLES["s1"]})
    fake = FakeLocal(lambda m: {"answer": "Stop."})  # read as the option 'stop'
    monkeypatch.setitem(registry._FACTORIES, "local", lambda model, **kw: fake)
    res = CliRunner().invoke(app, ["probe", str(ds), "--llm", "local", "--layers", "planning,counterfactual"])
    assert res.exit_code == 0, res.output
    assert TEXT_ONLY_NOTE.format(name="local") in res.output
    assert "text-only: the local model reads no images; questions asked with the privileged information as text" \
        in res.output
    assert len(fake.requests) == 2
    for messages in fake.requests:
        assert "images" not in messages[-1]
        assert "t = 5.0 s:\n  ego (ego ego): x 50.0" in messages[-1]["content"]
        assert "s1_cause (agent sedan): x 25.0" in messages[-1]["content"]
    doc = _doc(ds / "probe-local")
    assert [(q["qa_id"], q["answer"], q["correct"]) for q in doc["questions"]] == [
        ("s1-03", "stop", True), ("s1-04", "stop", False)]
    assert doc["note"] == TEXT_ONLY_NOTE.format(name="local")
    assert "layer: planning" in res.output and "flips correct 0" in res.output


def test_a_folder_that_is_not_a_dataset_and_an_unknown_layer_exit_2(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["probe", str(tmp_path), "--llm", "local"])
    assert res.exit_code == 2
    assert "is not a regen dataset (no samples.parquet and qa.parquet): give the --out folder of 'regen dataset'" \
        in res.output
    assert len(res.output.strip().splitlines()) == 1
    ds = write_dataset(tmp_path / "ds", {"s1": SAMPLES["s1"]})
    res = CliRunner().invoke(app, ["probe", str(ds), "--layers", "planning,vision"])
    assert res.exit_code == 2
    assert "--layers takes perception,prediction,planning,counterfactual (comma-separated), not 'vision'" in res.output
    assert not (ds / "probe-local").exists()


def test_a_rerun_replays_the_cached_answers_into_the_same_files(tmp_path: Path) -> None:
    ds = write_dataset(tmp_path / "ds")
    probe_dataset(ds, keyed(ds), out=tmp_path / "probe")
    first = {n: (tmp_path / "probe" / n).read_bytes() for n in (PROBE_JSON, REPORT, CONFUSION)}
    # replay: a model that would answer otherwise is never called
    res = probe_dataset(ds, always("yield"), out=tmp_path / "probe", replay=True)
    assert res.score.overall.accuracy == 1.0
    assert {n: (tmp_path / "probe" / n).read_bytes() for n in first} == first


def test_a_long_probe_tells_its_progress_in_a_log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Not a terminal (a log, CI): one line every 10 answers and at the end, with the count of
    correct answers so far; the library hook sees every answer in order."""
    ds = write_dataset(tmp_path / "ds")  # 16 scored questions
    fake = FakeLocal(lambda m: {"answer": "stop"})
    monkeypatch.setitem(registry._FACTORIES, "local", lambda model, **kw: fake)
    res = CliRunner().invoke(app, ["probe", str(ds), "--llm", "local"])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "answered" in ln]
    assert [re.search(r"(\d+)/16 answered", ln).group(1) for ln in lines] == ["10", "16"]
    sc = probe_dataset(ds, always("stop"), out=tmp_path / "again").score
    assert lines[-1].endswith(f"16/16 answered, {sc.overall.correct} correct so far")
    seen: list[tuple[int, int, bool | None]] = []
    probe_dataset(ds, always("stop"), out=tmp_path / "hook", on_answer=lambda d, n, a: seen.append((d, n, a.correct)))
    assert [d for d, _, _ in seen] == list(range(1, 17)) and {n for _, n, _ in seen} == {16}
    assert sum(c is True for _, _, c in seen) == sc.overall.correct
