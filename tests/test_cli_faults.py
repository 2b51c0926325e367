"""A run survives every fault: broken inputs give a one-line error that says what to do (exit
2), never a traceback; broken files inside a run folder are shown with their problem."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from regen.cli import app
from regen.core.behavior import Behavior
from regen.core.io import write_json
from regen.core.verdict import Verdict

STOP = "the ego-vehicle stops abruptly while driving forward"


def _run(*args: str, columns: int = 100):
    return CliRunner().invoke(app, list(args), env={"COLUMNS": str(columns)})


def _one_line_error(res, *says: str) -> str:
    """The output is exactly one 'error: ...' line holding every phrase of ``says``."""
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    assert lines[0].startswith("error: "), res.output
    for phrase in says:
        assert phrase in lines[0], (phrase, lines[0])
    return lines[0]


def _clean_exit(res) -> str:
    assert res.exit_code == 0, (res.output, res.exception)
    assert "Traceback" not in res.output
    return res.output


# --- regen assets FILE ---------------------------------------------------------------------------


def _driving_db() -> dict:
    return json.loads(_clean_exit(_run("assets", "driving", "--json")))


def test_assets_non_utf8_file(tmp_path: Path) -> None:
    bad = tmp_path / "db.json"
    bad.write_bytes(b'{"name": "caf\xe9"}')
    _one_line_error(_run("assets", str(bad)), str(bad), "not UTF-8", "save it as UTF-8")


def test_assets_folder(tmp_path: Path) -> None:
    _one_line_error(_run("assets", str(tmp_path)), "is a folder", "give", ".json")


def test_assets_missing_file(tmp_path: Path) -> None:
    _one_line_error(_run("assets", str(tmp_path / "nope.json")), "driving", "give")


def test_assets_deeply_nested_json(tmp_path: Path) -> None:
    bad = tmp_path / "deep.json"
    bad.write_text("[" * 100_000)
    _one_line_error(_run("assets", str(bad)), str(bad), "nested too deeply", "JSON object")


def test_assets_names_with_markup_are_printed_as_written(tmp_path: Path) -> None:
    db = _driving_db()
    db["name"] = "my [bold]db[/]"
    db["categories"]["odd [/] things"] = ["box [/]"]
    db["assets"]["box [/]"] = {"kind": "object", "description": "[red]a box[/red]"}
    path = tmp_path / "db.json"
    path.write_text(json.dumps(db))
    out = _clean_exit(_run("assets", str(path), columns=200))
    assert "odd [/] things" in out and "box [/]" in out and "my [bold]db[/]" in out
    assert "box [/]" in json.loads(_clean_exit(_run("assets", str(path), "--json")))["assets"]


@pytest.mark.parametrize("bad", ["\ud83d", "\x00", "\x1b[31m"])
def test_assets_name_with_control_character_or_lone_surrogate(tmp_path: Path, bad: str) -> None:
    db = _driving_db()
    db["categories"]["things"] = [f"box{bad}"]
    db["assets"][f"box{bad}"] = {"kind": "object", "description": "a box"}
    path = tmp_path / "db.json"
    path.write_text(json.dumps(db))  # ASCII: the file holds the escape, e.g. \ud83d
    line = _one_line_error(_run("assets", str(path)), "categories.things[0] = 'box\\u", "control character or lone surrogate")
    assert "\x1b" not in line and "\x00" not in line


# --- regen runs show / list ----------------------------------------------------------------------


def _verdict() -> Verdict:
    return Verdict(feasible=True, status="verified", reason="all 1 stages reached in order")


def _make_run(root: Path, name: str, *, manifest: str | bytes | None = None, verdict: str | None = None,
              summary: str | None = None, **fields) -> Path:
    run = root / name
    scen = run / "scenarios" / "01-a-child-runs"
    scen.mkdir(parents=True)
    write_json(scen / "verdict.json", _verdict())
    if verdict is not None:
        (scen / "verdict.json").write_text(verdict)
    data = {"behavior": Behavior(text=STOP, domain="driving").model_dump(mode="json"),
            "settings": {}, "status": "done", "started": "2025-01-02T10:00:00+00:00",
            "scenarios": ["01-a-child-runs"], **fields}
    if isinstance(manifest, bytes):
        (run / "run.json").write_bytes(manifest)
    else:
        (run / "run.json").write_text(json.dumps(data) if manifest is None else manifest)
    if summary is not None:
        (run / "summary.json").write_text(summary)
    return run


@pytest.mark.parametrize("verdict", ["{nope", "[" * 100_000, "\x00\xff", '{"status": 3}'])
def test_runs_show_corrupt_verdict_is_shown_as_unreadable(tmp_path: Path, verdict: str) -> None:
    run = _make_run(tmp_path, "run", verdict=verdict)
    out = _clean_exit(_run("runs", "show", str(run)))
    assert "01-a-child-runs" in out and "verdict unreadable" in out


@pytest.mark.parametrize("manifest", ["{", "[" * 100_000, "[]", '{"behavior": 1}',
                                      b'{"status": "caf\xe9"}'])
def test_runs_show_corrupt_run_json(tmp_path: Path, manifest: str | bytes) -> None:
    run = _make_run(tmp_path, "run", manifest=manifest)
    # the advice is safe for a folder that may not be a run at all: never --fresh on it
    line = _one_line_error(_run("runs", "show", str(run)), "run.json", "unreadable",
                           f"move {run} aside", "another --out")
    assert "--fresh" not in line


def test_runs_show_missing_run_json(tmp_path: Path) -> None:
    _one_line_error(_run("runs", "show", str(tmp_path)), "not a run folder", "give",
                    "regen runs list")


def test_runs_show_hostile_text_in_run_and_verdict(tmp_path: Path) -> None:
    hostile = "x [/] \ud83d \x07 \x1b[31m \u202egnp.exe\u202c y"  # a right-to-left override too
    run = _make_run(tmp_path, "run", started="[/]", status="[bold]done",
                    behavior={"text": hostile, "domain": "driving"},
                    verdict=json.dumps({"feasible": False, "status": "fsm_[/]incomplete",
                                        "reason": hostile}))
    out = _clean_exit(_run("runs", "show", str(run), columns=200))
    assert "x [/]" in out and "[/]" in out and "[bold]done" in out
    assert "\x07" not in out and "\x1b" not in out
    assert "\u202e" not in out and "\u202c" not in out and "gnp.exe" in out
    out.encode("utf-8")


def test_runs_list_shows_broken_runs_with_their_problem(tmp_path: Path) -> None:
    _make_run(tmp_path, "good-run-with-a-long-name", summary=json.dumps({"feasible": 1, "scenarios": 1}))
    _make_run(tmp_path, "bad-summary-run-with-a-long-name", summary="{")
    _make_run(tmp_path, "bad-manifest-run-with-a-long-name", manifest="{")
    _make_run(tmp_path, "deep-manifest-run", manifest="[" * 100_000)
    out = _clean_exit(_run("runs", "list", str(tmp_path), columns=400))
    for name in ("good-run-with-a-long-name", "bad-summary-run-with-a-long-name",
                 "bad-manifest-run-with-a-long-name", "deep-manifest-run"):
        assert f"│ {name} " in out, name  # named relative to the root in the title
    assert "1/1" in out
    assert out.count("summary.json unreadable") == 1
    assert out.count("run.json unreadable") == 2
    narrow = _clean_exit(_run("runs", "list", str(tmp_path), columns=80))
    assert "…" not in narrow  # long paths and problems wrap; none is cut short


def test_runs_list_of_a_missing_folder(tmp_path: Path) -> None:
    _one_line_error(_run("runs", "list", str(tmp_path / "nope")), "not a folder", "give")


def test_runs_list_hostile_text(tmp_path: Path) -> None:
    run = _make_run(tmp_path, "run", started="[/]", summary=json.dumps({"feasible": "[/]", "scenarios": "\ud83d"}),
              behavior={"text": "a [/] \ud83d \x00 b", "domain": "dri[/]ving"})
    out = _clean_exit(_run("runs", "list", str(tmp_path), columns=200))
    assert "a [/]" in out and "dri[/]ving" in out and "\x00" not in out
    out.encode("utf-8")
    alone = _clean_exit(_run("runs", "list", str(run), columns=200))  # a run folder itself
    assert str(run) in alone and "a [/]" in alone


# --- --llm local:<path that is not a model> ------------------------------------------------------


def _not_gguf(tmp_path: Path) -> Path:
    p = tmp_path / "notes.gguf"
    p.write_text("these are notes, not a model\n")
    return p


def _broken_gguf(tmp_path: Path) -> Path:
    p = tmp_path / "broken.gguf"
    p.write_bytes(b"GGUF" + b"\x03\x00\x00\x00" + b"\xff" * 64)  # the magic, then garbage
    return p


CASES = {
    "missing": (lambda t: t / "nope.gguf", ["neither a known model nor an existing file", "give the path of a .gguf model"]),
    "folder": (lambda t: t, ["is a folder", "give the path of a .gguf model"]),
    "not_gguf": (_not_gguf, ["not a GGUF model file", "give the path of a .gguf model"]),
    "broken_gguf": (_broken_gguf, ["cannot be loaded", "give the path of a .gguf model"]),
}


@pytest.mark.parametrize("command", ["generate", "expand"])
@pytest.mark.parametrize("case", list(CASES))
def test_local_model_path_that_is_not_a_model(tmp_path: Path, command: str, case: str) -> None:
    pytest.importorskip("llama_cpp")
    make, says = CASES[case]
    models = tmp_path / "models"
    models.mkdir()
    target = make(models)
    args = [command, STOP, "--domain", "driving", "--out", str(tmp_path / "out"),
            "--llm", f"local:{target}", "--cache", str(tmp_path / "cache.sqlite")]
    if command == "generate":
        args = [a for a in args if a not in ("--cache", str(tmp_path / "cache.sqlite"))]
        args += ["--log", "quiet"]
    line = _one_line_error(_run(*args, columns=300), *says)
    assert str(target) in line
