"""The dataset of a hand-built run folder: its files load with pandas and datasets, the left-out
scenarios are counted by reason, a rebuild is byte for byte the same, and the command refuses
a folder that is not a run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dataset_builders import write_run
from PIL import Image
from typer.testing import CliRunner

from regen.cli import app
from regen.dataset import build_dataset
from regen.dataset import write as dataset_write

pytest.importorskip("pyarrow", reason="the 'dataset' extra is not installed")


def _fake_camera(scenario, trace, times, *, size=(640, 360), map_path=None):
    return [Image.new("RGB", size, (int(10 * t) % 255, 80, 120)) for t in times]


@pytest.fixture
def no_camera(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dataset_write, "camera", lambda: (None, "no camera in this test"))


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.usefixtures("no_camera")
def test_dataset_of_a_run_loads_with_pandas_and_datasets(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import pandas as pd

    run = write_run(tmp_path)
    out = tmp_path / "ds"
    res = build_dataset([run], out, formats=("parquet", "llava"))
    assert res.samples == 1
    assert dict(res.left_out) == {"causal not_sufficient": 1, "trace contradicts the label": 1,
                                  "verdict fsm_incomplete": 1}
    samples = pd.read_parquet(out / "samples.parquet")
    assert list(samples["action"]) == ["stop"] and list(samples["sample_id"]) == ["a1"]
    assert [c for c in samples.columns if "image" in c] == [f"camera_image_{k}" for k in range(3)] + \
        [f"bev_image_{k}" for k in range(3)]
    row = samples.iloc[0]
    assert list(row["frame_times"]) == [4.0, 4.5, 5.0]
    assert pd.isna(row["camera_image_0"])
    assert (out / row["bev_image_2"]).is_file()
    assert [e["name"] for e in row["privileged"][2]["entities"]] == ["car1", "ego"]
    qa = pd.read_parquet(out / "qa.parquet")
    assert list(qa.columns) == ["qa_id", "sample_id", "pair_id", "layer", "question", "answer", "computed_from",
                                "options", "key"]
    planning = qa[qa["layer"] == "planning"].iloc[0]
    assert planning["key"] == "stop" and "stop" in list(planning["options"])
    overview = qa[qa["question"].str.startswith("Which")].iloc[0]
    assert pd.isna(overview["key"]) and list(overview["options"]) == []  # not scored
    assert all(k in list(o) for k, o in zip(qa["key"], qa["options"], strict=True) if not pd.isna(k))
    assert set(qa["layer"]) == {"perception", "prediction", "planning", "counterfactual"}
    whatif = qa[qa["question"] == "What if we remove car1?"]["answer"].item()
    # the reference driver in the edited world, not the what-if's scripted ego (which still brakes)
    assert whatif.startswith("keep_speed:") and "never stops" in whatif
    card = (out / "README.md").read_text()
    assert "No camera pictures" in card and "| causal not_sufficient | 1 |" in card
    assert "t-1.0 s, t-0.5 s, t" in card
    llava = json.loads((out / "llava.json").read_text())
    assert llava[0]["image"] == [f"images/a1/bev_{k}.png" for k in range(3)]
    assert llava[0]["conversations"][0]["value"].startswith("<image>\n<image>\n<image>\n")
    assert llava[0]["conversations"][1]["value"].startswith("stop.")

    datasets = pytest.importorskip("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    ds = datasets.load_dataset("parquet", data_files={"train": str(out / "samples.parquet")},
                               cache_dir=str(tmp_path / "hf"))["train"]
    assert ds.num_rows == 1 and ds[0]["action"] == "stop" and "bev_image_0" in ds.column_names
    qa_ds = datasets.load_dataset("parquet", data_files={"train": str(out / "qa.parquet")},
                                  cache_dir=str(tmp_path / "hf"))["train"]
    assert qa_ds.num_rows == len(qa)


def test_building_twice_gives_the_same_bytes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dataset_write, "camera", lambda: (_fake_camera, ""))
    run = write_run(tmp_path)
    build_dataset([run], tmp_path / "a", formats=("parquet", "llava"))
    build_dataset([run], tmp_path / "b", formats=("parquet", "llava"))
    a, b = _files(tmp_path / "a"), _files(tmp_path / "b")
    assert "images/a1/camera_2.png" in a
    assert a == b
    build_dataset([run], tmp_path / "a", formats=("parquet", "llava"))  # replaces its own dataset
    assert _files(tmp_path / "a") == b
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folder left


def test_a_folder_that_is_not_a_run_is_refused_in_one_line(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["dataset", str(tmp_path), "--out", str(tmp_path / "ds")])
    assert res.exit_code == 2
    assert "is not a run folder (no run.json): give the --out folder of 'regen generate'" in res.output
    assert not (tmp_path / "ds").exists()


@pytest.mark.usefixtures("no_camera")
def test_a_folder_with_other_files_is_never_replaced(tmp_path: Path) -> None:
    run = write_run(tmp_path)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    res = CliRunner().invoke(app, ["dataset", str(run), "--out", str(tmp_path / "mine"), "--log", "quiet"])
    assert res.exit_code == 2 and "not a regen dataset" in res.output
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


@pytest.mark.usefixtures("no_camera")
def test_a_rebuild_keeps_the_probe_folders(tmp_path: Path) -> None:
    run = write_run(tmp_path)
    build_dataset([run], tmp_path / "ds")
    (tmp_path / "ds" / "probe-local").mkdir()
    (tmp_path / "ds" / "probe-local" / "probe.json").write_text("{}")
    build_dataset([run], tmp_path / "ds")  # the probe's folder is no foreign file, and its cache is kept
    assert (tmp_path / "ds" / "probe-local" / "probe.json").read_text() == "{}"
