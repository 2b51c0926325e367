"""The holes of issue 37 that :mod:`regen.promises` closes (folders, names, terminal, secrets), one
test (or more) each, through the CLI and with the fake driving domain (no simulator):

1. ``generate --fresh`` removed a user's files inside a run's scenario folders; it removes exactly
   what the run wrote, refuses anything else with the list, and keeps ``whatif/`` and ``augment/``.
2. a provider echoing the request's ``Authorization`` header in a 400 put the key on the
   terminal, in ``run.json`` and the report (a loopback server).
3. ``eval --fidelity`` used a case id as a folder name: ``../x`` wrote outside ``--out``.
5. ``--out`` naming a file: tracebacks from ``whatif``, ``augment`` and ``eval --fidelity``.
8. ``whatif`` and ``augment`` on a scenario folder outside a run wrote two levels up.
11. ``augment`` printed a model's raw line breaks (U+2028 too): an answer could fake a line.
"""

from __future__ import annotations

import json
import logging
import shutil
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest
from fake_backend import FakeBackend
from fake_expansion_model import ScriptedModel
from typer.testing import CliRunner

from regen import domains
from regen.cli import app
from regen.llm import registry
from regen.llm.testing import FunctionProvider, QueuedProvider

STOP = "the ego-vehicle stops abruptly while driving forward"
CAUSES = ["debris lies ahead", "a bus blocks the lane"]


@pytest.fixture
def fake_driving(monkeypatch):
    monkeypatch.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
    FakeBackend.simulated = []
    model = ScriptedModel(causes={STOP: CAUSES}, entities={CAUSES[0]: ["debris"], CAUSES[1]: ["bus"]})
    monkeypatch.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
    return model


def _cli(*args: str, env: dict[str, str] | None = None):
    return CliRunner().invoke(app, list(args), env={"COLUMNS": "200", **(env or {})})


def _generate(run: Path, *extra: str):
    return _cli("generate", STOP, "--domain", "driving", "--llm", "scripted", "--log", "quiet",
                "--out", str(run), *extra)


def _one_line_error(res, *says: str) -> str:
    """The output is exactly one 'error: ...' line holding every phrase of ``says``, exit 2."""
    assert res.exit_code == 2, (res.exit_code, res.output, res.exception)
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    for phrase in says:
        assert phrase in lines[0], (phrase, lines[0])
    return lines[0]


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture
def run(tmp_path, fake_driving) -> Path:
    """A finished run of the fake driving domain: RUN/scenarios/01-debris-lies-ahead, 02-..."""
    folder = tmp_path / "run"
    res = _generate(folder)
    assert res.exit_code == 0, res.output
    return folder


def _scenes(run: Path) -> list[Path]:
    return sorted(p for p in (run / "scenarios").iterdir() if p.is_dir())


# --- hole 1: --fresh and the user's files inside scenario folders ------------------------------


def test_hole1_fresh_refuses_a_users_files_inside_scenario_folders_and_removes_nothing(run):
    first, second = _scenes(run)
    (first / "my_notes.txt").write_text("mine")
    (second / "mydata").mkdir()
    (second / "mydata" / "keep.csv").write_text("a,b\n1,2\n")
    before = _files(run)
    line = _one_line_error(_generate(run, "--fresh"), "--fresh", "holds what a run does not write",
                           "nothing was removed", "choose another --out")
    assert f"scenarios/{first.name}/my_notes.txt" in line and f"scenarios/{second.name}/mydata/" in line
    assert _files(run) == before  # not one file of the run went either


def test_hole1_fresh_removes_what_the_domain_wrote_even_unlisted(run, monkeypatch):
    wrote: list[Path] = []

    def render(self, scenario, trace, verdict, out_dir):
        (out_dir / "scratch.bin").write_bytes(b"a simulator's leftover")  # written, never returned
        gif = out_dir / "anim.gif"
        gif.write_bytes(b"GIF89a")
        wrote.append(out_dir)
        return {"animation": gif}

    monkeypatch.setattr(FakeBackend, "render", render)
    fresh = run.parent / "run2"
    assert _generate(fresh).exit_code == 0
    recorded = json.loads((wrote[0] / "written.json").read_text())
    assert recorded == ["anim.gif", "scratch.bin"]
    monkeypatch.setattr(FakeBackend, "render", lambda self, *a: {})  # the fresh run draws nothing
    res = _generate(fresh, "--fresh")
    assert res.exit_code == 0, res.output
    assert not any((d / "scratch.bin").exists() or (d / "anim.gif").exists() for d in wrote)


def test_hole1_an_older_run_without_its_record_is_judged_by_name(run):
    first = _scenes(run)[0]
    (first / "written.json").unlink(missing_ok=True)  # as a run made before the record was kept
    files = json.loads((first / "files.json").read_text())
    (first / "anim.gif").write_bytes(b"GIF89a")
    (first / "files.json").write_text(json.dumps({**files, "animation": "anim.gif"}))
    (first / "stray.bin").write_bytes(b"?")
    line = _one_line_error(_generate(run, "--fresh"), "holds what a run does not write")
    assert f"scenarios/{first.name}/stray.bin" in line and "anim.gif" not in line
    (first / "stray.bin").unlink()
    assert _generate(run, "--fresh").exit_code == 0
    assert not (first / "anim.gif").exists()  # files.json named it: the run's


def test_hole1_fresh_keeps_what_whatif_and_augment_wrote_into_the_run(run, monkeypatch):
    scene = _scenes(run)[0]
    res = _cli("whatif", str(scene), "--remove", "a1", "--no-judge", "--no-pictures")
    assert res.exit_code == 0, res.output
    provider = QueuedProvider([{"add": [], "irrelevant": ["a1"]}])
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: provider)
    res = _cli("augment", str(scene), "--llm", "queued:test", "--no-judge", "--no-pictures")
    assert res.exit_code == 0, res.output
    def theirs() -> dict[str, bytes]:  # their model caches' own files come and go with SQLite's checkpoints
        return {k: v for k, v in _files(run).items()
                if k.startswith(("whatif/", "augment/")) and "llm-cache" not in k}

    kept = theirs()
    assert any(k.endswith("whatif.json") for k in kept) and any(k.endswith("augment.json") for k in kept)
    res = _generate(run, "--fresh")
    assert res.exit_code == 0, res.output
    assert theirs() == kept and (run / "augment" / "llm-cache.sqlite").is_file()


# --- hole 2: a provider's error that echoes the key ---------------------------------------------

KEY = "sk-loopback-7Hq2Zr9Xw4Pm6Tn1Lk8Vb3Jc5"


class _Echo(BaseHTTPRequestHandler):
    """Answers every POST with 400 and the request: its headers, then its whole body."""

    def log_message(self, *args: Any) -> None:
        pass

    def do_POST(self) -> None:
        body = self.rfile.read(int(self.headers.get("content-length") or 0))
        echo = {"error": {"message": "bad request", "headers": dict(self.headers.items()),
                          "path": self.path, "body": body.decode("utf-8", "replace")}}
        data = json.dumps(echo).encode()
        self.send_response(400)
        self.send_header("content-type", "application/json")
        self.send_header("content-length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)


@pytest.fixture
def echo_server() -> Iterator[str]:
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), _Echo)
    httpd.daemon_threads = True
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}/v1"
    finally:
        httpd.shutdown()
        httpd.server_close()


@pytest.mark.parametrize("provider", ["openai", "anthropic"])
def test_hole2_a_key_echoed_in_an_error_body_lands_nowhere(tmp_path, fake_driving, echo_server, caplog,
                                                           provider):
    caplog.set_level(logging.DEBUG)
    folder = tmp_path / "run"
    env = ({"REGEN_OPENAI_BASE_URL": echo_server, "REGEN_OPENAI_API_KEY": KEY} if provider == "openai"
           else {"REGEN_ANTHROPIC_BASE_URL": f"{echo_server}/messages", "REGEN_ANTHROPIC_API_KEY": KEY})
    res = _cli("-v", "generate", STOP, "--domain", "driving", "--llm", f"{provider}:m", "--log", "jsonl",
               "--out", str(folder), env=env)
    assert res.exit_code == 2, res.output
    assert "HTTP 400" in res.output and "[redacted]" in res.output  # the error is told, the key is not
    from regen.report import write_report

    write_report(folder)  # the report of the failed run, as `regen runs show` users open it
    landed = {"terminal": res.output, "log": caplog.text,
              **{str(p.relative_to(folder)): p.read_text(errors="replace")
                 for p in folder.rglob("*") if p.is_file() and not p.name.startswith("llm-cache")}}
    assert {"run.json", "events.jsonl", "report.html"} <= set(landed)
    for where, text in landed.items():
        for k in range(len(KEY) - 8):  # not the key, nor any piece of 9 characters of it
            assert KEY[k:k + 9] not in text, (where, KEY[k:k + 9])
    assert "[redacted]" in json.loads((folder / "run.json").read_text())["message"]


# --- hole 3: a case id is a folder name ---------------------------------------------------------


def _case(case_id: str) -> str:
    return json.dumps({"id": case_id, "domain": "driving", "behavior": STOP, "ego_template": "stop_abruptly",
                       "cause": CAUSES[0], "entities": [{"any_of": ["debris"]}], "split": "test"})


@pytest.mark.parametrize("case_id", ["../escaped", "ABSOLUTE", "a/b"])
def test_hole3_a_case_id_never_writes_outside_out(tmp_path, fake_driving, case_id):
    outside = tmp_path / "outside"
    case_id = str(outside) if case_id == "ABSOLUTE" else case_id
    cases = tmp_path / "cases.jsonl"
    cases.write_text(_case("fine-1") + "\n" + _case(case_id) + "\n")
    out = tmp_path / "out"
    line = _one_line_error(_cli("eval", "--fidelity", str(cases), "--out", str(out), "--llm", "scripted"),
                           "the case id", "cannot name a folder", "give a plain name")
    assert case_id[:20] in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cases.jsonl", "out"]
    assert list(out.iterdir()) == []  # refused before any case ran


# --- hole 5: --out naming a file ----------------------------------------------------------------


@pytest.mark.parametrize("command", ["whatif", "augment", "eval --fidelity", "expand"])
def test_hole5_out_naming_a_file_is_one_line(run, tmp_path, monkeypatch, command):
    a_file = tmp_path / "taken.txt"
    a_file.write_text("mine")
    monkeypatch.setitem(registry._FACTORIES, "queued",
                        lambda name, **kw: QueuedProvider([{"add": [], "irrelevant": []}]))
    scene = str(_scenes(run)[0])
    cases = tmp_path / "cases.jsonl"
    cases.write_text(_case("c1") + "\n")
    args = {"whatif": ["whatif", scene, "--remove", "a1", "--no-pictures", "--llm", "queued"],
            "augment": ["augment", scene, "--llm", "queued:test", "--no-pictures"],
            "eval --fidelity": ["eval", "--fidelity", str(cases), "--llm", "scripted"],
            "expand": ["expand", STOP, "--domain", "driving", "--llm", "scripted"]}[command]
    for out, words in ((a_file, "is a file; give a folder"), (a_file / "sub", "lies under a file")):
        _one_line_error(_cli(*args, "--out", str(out)), f"--out {out}", words)
    assert a_file.read_text() == "mine"


# --- hole 8: a scenario folder outside a run ----------------------------------------------------


@pytest.mark.parametrize("command", ["whatif", "augment"])
def test_hole8_a_scenario_folder_outside_a_run_needs_out(run, tmp_path, monkeypatch, command):
    loose = tmp_path / "loose" / "scenes" / "01-scene"
    shutil.copytree(_scenes(run)[0], loose)
    before = sorted(p.relative_to(tmp_path / "loose") for p in (tmp_path / "loose").rglob("*"))
    monkeypatch.setitem(registry._FACTORIES, "queued",
                        lambda name, **kw: QueuedProvider([{"add": [], "irrelevant": ["a1"]}]))
    args = {"whatif": ["whatif", str(loose), "--remove", "a1", "--no-judge", "--no-pictures"],
            "augment": ["augment", str(loose), "--llm", "queued:test", "--no-judge", "--no-pictures"]}[command]
    _one_line_error(_cli(*args), str(loose), "not a scenario folder of a run", "--out FOLDER")
    assert sorted(p.relative_to(tmp_path / "loose") for p in (tmp_path / "loose").rglob("*")) == before
    res = _cli(*args, "--out", str(tmp_path / "mine"))  # said where: written there
    assert res.exit_code == 0, res.output
    assert (tmp_path / "mine").is_dir()
    assert sorted(p.relative_to(tmp_path / "loose") for p in (tmp_path / "loose").rglob("*")) == before


# --- hole 11: a model's line breaks on the terminal ---------------------------------------------


def test_hole11_a_models_line_breaks_cannot_fake_a_terminal_line(run, monkeypatch):
    answer = {"add": [], "irrelevant": ["ghost\u2028error: fake one", "x\nerror: fake two", "para\u2029graph"]}
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: QueuedProvider([answer]))
    res = _cli("augment", str(_scenes(run)[0]), "--llm", "queued:test", "--no-judge", "--no-pictures")
    assert res.exit_code == 0, res.output
    assert not any(ln.lstrip().startswith("error:") for ln in res.output.splitlines()), res.output
    assert not any(c in res.output for c in "\u2028\u2029")
    ignored = next(ln for ln in res.output.splitlines() if "not in the scene, ignored:" in ln)
    assert "ghost\\u2028error: fake one" in ignored and "x\\nerror: fake two" in ignored
    assert "para\\u2029graph" in ignored
