"""Issue 37, build 4: every command keeps the same promises against every kind of bad input.

Two tables. :data:`FAULTS` names the kinds of bad input and what a command must do with them;
:data:`COMMANDS` has one row per command (``generate``, ``expand``, ``test``, ``falsify``, ``whatif``,
``augment``, ``import``, ``eval``, ``runs``, and ``assets``; a mode of one, such as ``eval
--fidelity`` or ``runs show``, is a row of its own), mapping each fault the command can receive to an invocation that carries it, built
from a valid minimal one. A fault a command has no way to receive is not in its row (not a skip);
:func:`test_fault` runs every pair of the rows. A new command joins by adding a row.

Every pair keeps these promises:

- the exit code: 2 for bad input, with exactly one line ``error: ...`` (on stderr, nothing on
  stdout) that names the bad path where there is one, and no traceback; a killed run resumed
  finishes (exit 0, and the row checks what it finished);
- nothing written outside the area the command may write: its ``--out`` (for a resume, also
  what the row names, e.g. the run's report that ``regen test`` redraws). Each case works in
  its own folder (inputs, ``--out``, and the working folder the command runs in), all of it
  snapshot before and after, so a file two levels up, beside the input or in the working
  folder is found;
- no file that was there before removed or changed, but the killed run's own files that its
  resume finishes (a user's file put beside them is kept).

Nothing here calls a language model: the fake driving domain and a scripted model
(:mod:`test_promise_holes`), a queued model answering once and then from its cache, recorded
runs built once per module, and for ``regen test`` and ``regen import`` a real Scenic run of one
scenario (a few seconds, once).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # the tests folder is not a package
from regen.llm import registry  # noqa: E402
from regen.llm.testing import QueuedProvider  # noqa: E402
from regen.promises.files import MAX_BYTES  # noqa: E402
from test_cli_faults import _one_line_error  # noqa: E402
from test_promise_holes import CAUSES, STOP, _case, _cli, _generate, fake_driving  # noqa: E402, F401
from test_reading_holes import HAND, _result, _stop_rows, ran  # noqa: E402, F401

NOT_UTF8 = "café\n".encode("latin-1")  # a byte (0xe9) that is no UTF-8
AUGMENT_ANSWER = {"add": [], "irrelevant": ["a1"]}
KILLED = ".k1ll3d.tmp"  # the suffix of the temporary file an atomic write left when killed
USERS = "my-notes.txt"  # a user's own file beside a killed run: its resume keeps it


# --- the faults ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Fault:
    """A kind of bad input. ``refused``: the command exits 2 with one line (else it finishes);
    ``says``: words of which the line holds one (lower case), whichever command refuses it."""

    about: str
    refused: bool = True
    says: tuple[str, ...] = ()


FAULTS: dict[str, Fault] = {
    "missing": Fault("a path that does not exist, where a file or folder is expected"),
    "folder_for_file": Fault("a folder where a file is expected", says=("folder",)),
    "file_under_file": Fault("a file's path under a file (taken.txt/ego.csv)"),
    "file_for_folder": Fault("a file where a folder is expected"),
    "non_utf8": Fault("a text file holding a byte that is not UTF-8 (Latin-1 'é')"),
    "empty": Fault("an empty file"),
    "too_big": Fault(f"a file over the size cap ({MAX_BYTES} bytes, regen.promises.files; sparse)",
                     says=("larger than",)),
    "corrupt": Fault("a file of the right name that cannot be parsed (JSON, XML, CSV, Python, SQLite)"),
    "out_is_file": Fault("--out naming an existing file", says=("is a file",)),
    "out_under_file": Fault("--out under a file", says=("under a file",)),
    "out_foreign": Fault("--out a folder holding what the command did not write, where it would "
                         "remove its own files (--fresh)"),
    "not_a_run": Fault("a folder that is not a run (or a scenario folder that is not inside one)"),
    "name_escape": Fault("a name from user text with '..' and '/': refused where it names a folder "
                         "as it is, made a plain name where the command makes one (row: finishes)"),
    "killed": Fault("a killed run resumed: its temporary files, a cut-off line, a half-written "
                    "folder, a user's file beside it", refused=False),
}


# --- one case: its folders, what the injection said about it -------------------------------------


@dataclass
class Case:
    """One (command, fault) pair: ``root`` holds everything it may see; ``inputs`` what the
    command reads, ``out`` its --out, ``cwd`` the folder it runs in (none of which exist beyond
    ``root`` before the injection makes them)."""

    root: Path
    request: Any  # pytest's: fixtures an injection needs, by name (see :meth:`fixture`)
    names: str | None = None  # what the error line must name (the bad path)
    may_write: list[Path] = field(default_factory=list)  # where a finishing command may write besides out
    # (new files, or changes to those there)
    own: set[str] = field(default_factory=set)  # files (relative to root) a resume may change
    finished: Callable[[Any], None] | None = None  # checks a finishing command's result
    refused: bool | None = None  # the row's answer for a fault that may go either way

    def fixture(self, name: str) -> Any:
        """The value of the fixture ``name`` (a module's are built once, at their first use)."""
        return self.request.getfixturevalue(name)

    @property
    def inputs(self) -> Path:
        return self.root / "inputs"

    @property
    def out(self) -> Path:
        return self.root / "out"

    @property
    def cwd(self) -> Path:
        return self.root / "cwd"

    def copy(self, folder: Path, to: Path) -> Path:
        """A copy of a fixture's folder at ``to`` (cases never touch the fixture itself)."""
        shutil.copytree(folder, to, symlinks=True)
        return to

    def killed(self, folder: Path, *, remove: list[str], cut: str | None = None,
               temp_in: str = ".") -> Path:
        """``folder`` (the command's finished output, already at its place under ``root``)
        turned into what a kill leaves: ``remove`` (globs) gone, the last line of ``cut`` (a
        JSON-lines file the command appends to) cut in half, a temporary file of an atomic
        write in ``temp_in``, and a user's file beside it all that the resume must keep."""
        for pattern in remove:
            for p in folder.glob(pattern):
                p.unlink()
        if cut is not None:
            log = folder / cut
            lines = log.read_text().splitlines(keepends=True)
            log.write_text("".join(lines[:-1]) + lines[-1][: len(lines[-1]) // 2])
        (folder / temp_in / f".verdict.json{KILLED}").write_text('{"feasible": tr')
        self.own = {rel for rel in _snapshot(self.root) if (self.root / rel).is_relative_to(folder)}
        (folder / USERS).write_text("mine: keep")
        return folder


Inject = Callable[[Case], list[str]]


def _bad_file(case: Case, fault: str, name: str, valid: str, corrupt: str) -> Path:
    """``inputs/<name>`` carrying a file fault (``valid``: the file's good text; ``corrupt``: a
    text that does not parse); the error line must name it."""
    p = case.inputs / name
    p.parent.mkdir(parents=True, exist_ok=True)
    if fault == "file_under_file":
        taken = case.inputs / "taken.txt"
        taken.write_text("mine")
        p = taken / name
    elif fault == "folder_for_file":
        p.mkdir()
    elif fault == "non_utf8":
        p.write_bytes(valid.encode("utf-8") + NOT_UTF8)
    elif fault == "empty":
        p.write_bytes(b"")
    elif fault == "too_big":
        with p.open("wb") as fh:  # sparse: no disk, no time
            fh.truncate(MAX_BYTES + 1)
    elif fault == "corrupt":
        p.write_text(corrupt, encoding="utf-8")
    else:
        assert fault == "missing", fault
    case.names = str(p)
    return p


FILE_FAULTS = ("missing", "folder_for_file", "file_under_file", "non_utf8", "empty", "too_big", "corrupt")


def file_faults(name: str, valid: str, corrupt: str, argv: Callable[[Case, Path], list[str]],
                faults: tuple[str, ...] = FILE_FAULTS) -> dict[str, Inject]:
    """The row entries of a command's file input: each fault a file named ``name`` can carry,
    passed as ``argv(case, path)`` says."""
    return {f: (lambda case, f=f: argv(case, _bad_file(case, f, name, valid, corrupt))) for f in faults}


def out_faults(argv: Callable[[Case, Path], list[str]]) -> dict[str, Inject]:
    """The row entries of a command's --out: a file in its place, a file on its path."""

    def on(kind: str) -> Inject:
        def inject(case: Case) -> list[str]:
            taken = case.inputs / "taken.txt"
            taken.parent.mkdir(parents=True, exist_ok=True)
            taken.write_text("mine")
            case.names = f"--out {taken}" if kind == "out_is_file" else str(taken)
            return argv(case, taken if kind == "out_is_file" else taken / "sub")
        return inject

    return {"out_is_file": on("out_is_file"), "out_under_file": on("out_under_file")}


def folder_faults(argv: Callable[[Case, Path], list[str]]) -> dict[str, Inject]:
    """The row entries of a command's folder input: a path that does not exist, a file."""

    def on(kind: str) -> Inject:
        def inject(case: Case) -> list[str]:
            p = case.inputs / "folder"
            p.parent.mkdir(parents=True, exist_ok=True)
            if kind == "file_for_folder":
                p.write_text("a file, not a folder")
            case.names = str(p)
            return argv(case, p)
        return inject

    return {f: on(f) for f in ("missing", "file_for_folder")}


def finishes(inject: Inject) -> Inject:
    """An entry whose command finishes (exit 0) though its fault is refused elsewhere: e.g. a
    name from user text that the command makes a plain name of."""

    def wrapped(case: Case) -> list[str]:
        case.refused = False
        return inject(case)

    return wrapped


def _json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def _set_status(run: Path, status: str) -> None:
    manifest = _json(run / "run.json")
    (run / "run.json").write_text(json.dumps({**manifest, "status": status, "finished": None}))


# --- fixtures built once per module --------------------------------------------------------------


@pytest.fixture(scope="module")
def _module_cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("regen-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(_module_cache, monkeypatch):
    """Overrides the root fixture: the cases share one cache (maps are generated once)."""
    monkeypatch.setenv("REGEN_CACHE_DIR", str(_module_cache))


@pytest.fixture(scope="module")
def fake_run(tmp_path_factory) -> Path:
    """A finished run of the fake driving domain (two scenarios, its model cache), made once by
    :func:`test_promise_holes._generate` with the same fake domain and scripted model as its
    ``fake_driving`` fixture, which every case using it runs under."""
    from fake_backend import FakeBackend
    from fake_expansion_model import ScriptedModel

    from regen import domains
    from regen.llm.testing import FunctionProvider

    model = ScriptedModel(causes={STOP: CAUSES}, entities={CAUSES[0]: ["debris"], CAUSES[1]: ["bus"]})
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(domains._REGISTRY, "driving", "fake_backend:FakeBackend")
        mp.setitem(registry._FACTORIES, "scripted", lambda name, **kw: FunctionProvider(model))
        FakeBackend.simulated = []
        folder = tmp_path_factory.mktemp("fake") / "run"
        res = _generate(folder)
        assert res.exit_code == 0, res.output
    return folder


@pytest.fixture(scope="module")
def driving_run(tmp_path_factory):
    """A run of one scenario verified in Scenic (a child crosses; the built-in 'aeb' policy
    passes it), made once."""
    pytest.importorskip("scenic")
    from driving_chains import FEASIBLE, verified_run

    yield from verified_run(tmp_path_factory, {"01-child-crosses": FEASIBLE["stop_abruptly"][0]})


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> Path:
    """The hand-written OpenSCENARIO file imported into a run, simulated in Scenic, made once
    (the folder holds ``crossing.xosc`` and ``run/``)."""
    pytest.importorskip("scenic")
    root = tmp_path_factory.mktemp("imported")
    shutil.copy(HAND, root / "crossing.xosc")
    res = _cli("import", str(root / "crossing.xosc"), "--out", str(root / "run"), "--no-pictures")
    assert res.exit_code == 0, res.output
    return root


@pytest.fixture
def recordings(monkeypatch) -> None:
    """The fake driving domain reads a recorded ego trajectory as the real one does."""
    from fake_backend import FakeBackend

    from regen.driving.backend import DrivingBackend

    monkeypatch.setattr(FakeBackend, "recorder", DrivingBackend.recorder)


@pytest.fixture
def queued(monkeypatch) -> None:
    """``--llm queued:test``: a model that answers the augment proposal once per client."""
    monkeypatch.setitem(registry._FACTORIES, "queued", lambda name, **kw: QueuedProvider([AUGMENT_ANSWER]))


# --- the rows ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """One command: the fixtures every invocation of it runs under (a fake domain, a queued
    model), and an invocation for each fault it can receive (the injection makes the case's
    inputs, asking for the fixtures it builds them from, and returns the arguments)."""

    fixtures: tuple[str, ...]
    faults: dict[str, Inject]


# generate ----------------------------------------------------------------------------------------

TRAJECTORY = "t,x,y,note\n" + "".join(f"{row},ok\n" for row in _stop_rows().splitlines())


def _generate_args(case: Case, out: Path | str, *extra: str) -> list[str]:
    return ["generate", STOP, "--domain", "driving", "--llm", "scripted", "--log", "quiet",
            "--no-pictures", "--out", str(out), *extra]


def _generate_trajectory(case: Case, f: Path) -> list[str]:
    return ["generate", "--domain", "driving", "--ego-trajectory", str(f), "--log", "quiet",
            "--out", str(case.out)]


def _generate_foreign(case: Case) -> list[str]:
    case.out.mkdir()
    (case.out / USERS).write_text("mine")
    (case.out / "data").mkdir()
    (case.out / "data" / "keep.csv").write_text("a,b\n1,2\n")
    case.names = USERS
    return _generate_args(case, case.out, "--fresh")


def _generate_not_a_run(case: Case) -> list[str]:
    case.out.mkdir()
    (case.out / "run.json").write_text('{"my": "own settings"}')  # another tool's file of that name
    (case.out / USERS).write_text("mine")
    case.names = "run.json"
    return _generate_args(case, case.out)


def _generate_name(case: Case) -> list[str]:
    escape = "../../escaped/x"
    case.fixture("fake_driving").entities[escape] = ["debris"]

    def finished(res) -> None:
        names = _json(case.out / "run.json")["scenarios"]
        assert any(n.endswith("-escaped-x") for n in names), names  # a plain name, inside the run

    case.finished = finished
    return _generate_args(case, case.out, "--cause", escape)


def _generate_killed(case: Case) -> list[str]:
    run = case.copy(case.fixture("fake_run"), case.out)
    second = sorted((run / "scenarios").iterdir())[1]
    _set_status(run, "running")
    case.killed(run, remove=["summary.json", "report.html", f"scenarios/{second.name}/verdict.json",
                             f"scenarios/{second.name}/trace.json"],
                cut="events.jsonl", temp_in=f"scenarios/{second.name}")

    def finished(res) -> None:
        assert _json(run / "run.json")["status"] == "done"
        assert (second / "verdict.json").is_file() and (run / "report.html").is_file()

    case.finished = finished
    return _generate_args(case, run)


GENERATE = Command(("fake_driving", "recordings"), {
    **file_faults("ego.csv", TRAJECTORY, "t,x,y\n0,0,0\n0.1,abc,0\n", _generate_trajectory),
    **out_faults(lambda case, out: _generate_args(case, out)),
    "out_foreign": _generate_foreign,
    "not_a_run": _generate_not_a_run,
    "name_escape": finishes(_generate_name),
    "killed": _generate_killed,
})


# expand ------------------------------------------------------------------------------------------


def _expand_args(case: Case, out: Path, *extra: str) -> list[str]:
    return ["expand", STOP, "--domain", "driving", "--llm", "scripted", "--out", str(out), *extra]


def _expand_cache(case: Case, f: Path) -> list[str]:
    return _expand_args(case, case.out, "--cache", str(f))


def _expand_killed(case: Case) -> list[str]:
    first = _cli(*_expand_args(case, case.out))
    assert first.exit_code == 0, first.output
    case.killed(case.out, remove=["graph.*"])

    def finished(res) -> None:
        assert _json(case.out / "graph.json")["behavior"]["text"] == STOP
        assert "2 simulatable cause chain(s)" in res.output

    case.finished = finished
    return _expand_args(case, case.out, "--replay")  # from its cache: no model is asked again


EXPAND = Command(("fake_driving",), {
    **file_faults("cache.sqlite", "", "not a database\n" * 100, _expand_cache,
                  faults=("folder_for_file", "file_under_file", "corrupt")),
    **out_faults(lambda case, out: _expand_args(case, out)),
    "killed": _expand_killed,
})


# test --------------------------------------------------------------------------------------------

POLICY = "def policy(observation):\n    return (1.0, 0.0)  # 'é' is fine in UTF-8\n"


def _run_copy(case: Case, name: str) -> Path:
    return case.copy(case.fixture(name), case.inputs / "run")


def _test_policy(case: Case, f: Path) -> list[str]:
    return ["test", str(_run_copy(case, "driving_run")), "--policy", str(f), "--out", str(case.out)]


def _test_folder(case: Case, folder: Path) -> list[str]:
    return ["test", str(folder), "--policy", "aeb", "--out", str(case.out)]


def _users_folder(case: Case) -> Path:
    """A folder of the user's own data, not a run (named in the expected error)."""
    folder = case.inputs / "mine"
    (folder / "data").mkdir(parents=True)
    (folder / "data" / "keep.csv").write_text("a,b\n1,2\n")
    case.names = str(folder)
    return folder


def _test_not_a_run(case: Case) -> list[str]:
    return _test_folder(case, _users_folder(case))


def _test_killed(case: Case) -> list[str]:
    run = _run_copy(case, "driving_run")
    args = ["test", str(run), "--policy", "aeb", "--out", str(case.out)]
    first = _cli(*args)
    assert first.exit_code == 0, first.output
    # killed after its case was kept, before tests.json and junit.xml were rebuilt
    case.killed(case.out, remove=["tests.json", "junit.xml"])
    case.may_write = [run / "report.html"]  # the run's report shows its tests

    def finished(res) -> None:
        assert "resuming" in res.output, res.output
        assert [c["status"] for c in _json(case.out / "tests.json")["cases"]] == ["passed"]

    case.finished = finished
    return args


TEST = Command(("driving_run",), {
    **file_faults("policy.py", POLICY, "def policy(o:\n", _test_policy,
                  faults=("missing", "folder_for_file", "file_under_file", "non_utf8", "empty", "corrupt")),
    **folder_faults(_test_folder),
    **out_faults(lambda case, out: ["test", str(_run_copy(case, "driving_run")), "--policy", "aeb",
                                    "--out", str(out)]),
    "not_a_run": _test_not_a_run,
    "killed": _test_killed,
})


# falsify -----------------------------------------------------------------------------------------

FALSIFY_OPTIONS = ("--budget", "1", "--param-budget", "0", "--no-pictures")


def _falsify(case: Case, run: Path, policy: str, out: Path) -> list[str]:
    return ["falsify", str(run), "--policy", policy, "--out", str(out), *FALSIFY_OPTIONS]


def _falsify_killed(case: Case) -> list[str]:
    run = _run_copy(case, "driving_run")
    args = _falsify(case, run, "aeb", case.out)
    first = _cli(*args)
    assert first.exit_code == 0, first.output
    before = _json(case.out / "falsify.json")
    # killed after its candidate was tested, before falsify.json was written
    case.killed(case.out, remove=["falsify.json"])
    case.may_write = [run / "report.html"]  # the run's report shows the search

    def finished(res) -> None:
        after = _json(case.out / "falsify.json")
        assert after["status"] == "done", after
        assert [(c["cid"], c["status"]) for c in after["candidates"]] == \
            [(c["cid"], c["status"]) for c in before["candidates"]]

    case.finished = finished
    return args


FALSIFY = Command(("driving_run",), {
    **file_faults("policy.py", POLICY, "def policy(o:\n",
                  lambda case, f: _falsify(case, _run_copy(case, "driving_run"), str(f), case.out),
                  faults=("missing", "folder_for_file", "file_under_file", "non_utf8", "empty", "corrupt")),
    **folder_faults(lambda case, folder: _falsify(case, folder, "aeb", case.out)),
    **out_faults(lambda case, out: _falsify(case, _run_copy(case, "driving_run"), "aeb", out)),
    "not_a_run": lambda case: _falsify(case, _users_folder(case), "aeb", case.out),
    "killed": _falsify_killed,
})


# whatif and augment ------------------------------------------------------------------------------

WHATIF_EDIT = ("--remove", "a1", "--no-judge", "--no-pictures")
AUGMENT_OPTIONS = ("--llm", "queued:test", "--no-judge", "--no-pictures")


def _scene(case: Case) -> Path:
    """The first scenario folder of a copy of the fake run."""
    run = _run_copy(case, "fake_run")
    return sorted((run / "scenarios").iterdir())[0]


OWN_FILE_FAULTS = ("non_utf8", "empty", "too_big", "corrupt")


def own_file_faults(folder: Callable[[Case], Path], name: str, argv: Callable[[Case, Path], list[str]]
                    ) -> dict[str, Inject]:
    """The row entries of a file the toolkit wrote into a folder the command is given (a run's
    run.json, a scenario's scenario.json), damaged: ``folder(case)`` makes the folder, whose
    file ``name`` is replaced by the fault (cut in half: corrupt), and ``argv(case, folder)``."""

    def on(fault: str) -> Inject:
        def inject(case: Case) -> list[str]:
            where = folder(case)
            valid = (where / name).read_text()
            (where / name).unlink()
            _bad_file(case, fault, str((where / name).relative_to(case.inputs)), valid, valid[: len(valid) // 2])
            return argv(case, where)
        return inject

    return {f: on(f) for f in OWN_FILE_FAULTS}


def _scene_rows(command: str, options: tuple[str, ...], *, killed: Inject) -> dict[str, Inject]:
    def not_a_run(case: Case) -> list[str]:
        loose = case.copy(_scene(case), case.inputs / "loose" / "scenes" / "01-scene")
        case.names = str(loose)
        return [command, str(loose), *options]  # no --out: two levels up is nobody's run

    return {
        **folder_faults(lambda case, p: [command, str(p), *options, "--out", str(case.out)]),
        **own_file_faults(_scene, "scenario.json",
                          lambda case, scene: [command, str(scene), *options, "--out", str(case.out)]),
        **out_faults(lambda case, out: [command, str(_scene(case)), *options, "--out", str(out)]),
        "not_a_run": not_a_run,
        "killed": killed,
    }


def _whatif_killed(case: Case) -> list[str]:
    args = ["whatif", str(_scene(case)), *WHATIF_EDIT, "--out", str(case.out)]
    first = _cli(*args)
    assert first.exit_code == 0, first.output
    (dest,) = case.out.iterdir()
    case.killed(dest, remove=["whatif.json", "whatif.html", "verdict.json"])

    def finished(res) -> None:
        assert _json(dest / "whatif.json")["edits"][0]["op"] == "remove"

    case.finished = finished
    return args


def _augment_killed(case: Case) -> list[str]:
    scene = _scene(case)
    first = _cli("augment", str(scene), *AUGMENT_OPTIONS, "--out", str(case.out))
    assert first.exit_code == 0, first.output
    dest = case.out / f"{scene.name}-augment"
    case.killed(case.out, remove=[f"{dest.name}/augment.*"], temp_in=dest.name)  # its model cache is its own too

    def finished(res) -> None:
        assert [t["proposal"] for t in _json(dest / "augment.json")["irrelevant"]] == ["a1"]

    case.finished = finished
    # the model's answer is in the cache beside the output: the resume asks no model
    return ["augment", str(scene), *AUGMENT_OPTIONS, "--out", str(case.out), "--replay"]


WHATIF = Command(("fake_driving",), _scene_rows("whatif", WHATIF_EDIT, killed=_whatif_killed))
AUGMENT = Command(("fake_driving", "queued"),
                  _scene_rows("augment", AUGMENT_OPTIONS, killed=_augment_killed))


# import ------------------------------------------------------------------------------------------


def _import_args(case: Case, f: Path | str, out: Path | str, *extra: str) -> list[str]:
    return ["import", str(f), "--out", str(out), "--no-pictures", *extra]


def _xosc(case: Case) -> Path:
    f = case.inputs / "crossing.xosc"
    f.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(HAND, f)
    return f


def _import_foreign(case: Case) -> list[str]:
    case.out.mkdir()
    (case.out / USERS).write_text("mine")
    case.names = USERS
    return _import_args(case, _xosc(case), case.out, "--fresh")


def _import_killed(case: Case) -> list[str]:
    src = case.fixture("imported")
    f = case.copy(src, case.inputs) / "crossing.xosc"
    run = case.copy(src / "run", case.out)
    _set_status(run, "running")
    scene = _json(run / "run.json")["scenarios"][0]
    case.killed(run, remove=["summary.json", "report.html"], temp_in=f"scenarios/{scene}")

    def finished(res) -> None:
        assert _json(run / "run.json")["status"] == "done" and (run / "report.html").is_file()

    case.finished = finished
    return _import_args(case, f, run)


IMPORT = Command((), {
    **file_faults("crossing.xosc", HAND.read_text(encoding="utf-8"), "<OpenSCENARIO><FileHeader",
                  lambda case, f: _import_args(case, f, case.out)),
    **out_faults(lambda case, out: _import_args(case, _xosc(case), out)),
    "out_foreign": _import_foreign,
    "killed": _import_killed,
})


# eval and eval --fidelity ------------------------------------------------------------------------

TEXTS = "".join(f"a pedestrian number {i} crosses the road\n" for i in range(6))


def _eval_args(case: Case, *sources: Path | str, out: Path | None = None) -> list[str]:
    return ["eval", *map(str, sources), "--no-embeddings", "--repeats", "1", "--out", str(out or case.out)]


def _texts(case: Case) -> Path:
    f = case.inputs / "causes.txt"
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_text(TEXTS)
    return f


def _eval_not_a_run(case: Case) -> list[str]:
    return _eval_args(case, _users_folder(case))


EVAL = Command((), {
    **file_faults("causes.json", json.dumps(TEXTS.splitlines()), '["a pedestrian crosses", ',
                  lambda case, f: _eval_args(case, f)),
    **out_faults(lambda case, out: _eval_args(case, _texts(case), out=out)),
    "not_a_run": _eval_not_a_run,
})

CASES_TEXT = _case("c1") + "\n"


def _fidelity_args(case: Case, f: Path, out: Path | None = None) -> list[str]:
    return ["eval", "--fidelity", str(f), "--out", str(out or case.out), "--llm", "scripted"]


def _cases_file(case: Case, text: str = CASES_TEXT) -> Path:
    f = case.inputs / "cases.jsonl"
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_text(text)
    return f


def _fidelity_name(case: Case) -> list[str]:
    case.names = "../escaped"
    return _fidelity_args(case, _cases_file(case, CASES_TEXT + _case("../escaped") + "\n"))


def _fidelity_killed(case: Case) -> list[str]:
    ids = case.fixture("ran")  # the ids of the cases run, each a verified result without a model
    cases = _cases_file(case, "".join(_case(i) + "\n" for i in ("a", "b", "c")))
    case.out.mkdir()
    (case.out / "fidelity.jsonl").write_text(json.dumps(_result("a")) + "\n" + json.dumps(_result("b")) + "\n")
    case.killed(case.out, remove=[], cut="fidelity.jsonl")

    def finished(res) -> None:
        assert ids == ["b", "c"]  # a was done; b was cut off, so it runs again
        rows = (case.out / "fidelity.jsonl").read_text().splitlines()
        assert [json.loads(r)["id"] for r in rows] == ["a", "b", "c"]

    case.finished = finished
    return _fidelity_args(case, cases)


FIDELITY = Command(("fake_driving",), {
    **file_faults("cases.jsonl", CASES_TEXT, '{"id": "c1", "domain": \n',
                  lambda case, f: _fidelity_args(case, f)),
    **out_faults(lambda case, out: _fidelity_args(case, _cases_file(case), out)),
    "name_escape": _fidelity_name,
    "killed": _fidelity_killed,
})


# runs show and runs list -------------------------------------------------------------------------


def _runs_killed(command: str) -> Inject:
    def inject(case: Case) -> list[str]:
        run = _run_copy(case, "fake_run")
        second = sorted((run / "scenarios").iterdir())[1]
        _set_status(run, "running")
        case.killed(run, remove=["summary.json", "report.html", f"scenarios/{second.name}/verdict.json"],
                    cut="events.jsonl")

        def finished(res) -> None:
            assert ("not finished" if command == "show" else "running") in res.output, res.output

        case.finished = finished
        return ["runs", command, str(run if command == "show" else case.inputs)]

    return inject


def _runs_not_a_run(case: Case) -> list[str]:
    folder = case.inputs / "mine"
    folder.mkdir(parents=True)
    (folder / USERS).write_text("mine")
    case.names = str(folder)
    return ["runs", "show", str(folder)]


RUNS_SHOW = Command((), {
    **folder_faults(lambda case, p: ["runs", "show", str(p)]),
    **own_file_faults(lambda case: _run_copy(case, "fake_run"), "run.json",
                      lambda case, run: ["runs", "show", str(run)]),
    "not_a_run": _runs_not_a_run,
    "killed": _runs_killed("show"),
})
RUNS_LIST = Command((), {
    **folder_faults(lambda case, p: ["runs", "list", str(p)]),
    "killed": _runs_killed("list"),
})


# assets ------------------------------------------------------------------------------------------

DATABASE = (Path(__file__).resolve().parents[1] / "src" / "regen" / "driving" / "data" / "assets.json")

ASSETS = Command((), file_faults("db.json", DATABASE.read_text(encoding="utf-8"), '{"name": "mine", ',
                                 lambda case, f: ["assets", str(f)]))


COMMANDS: dict[str, Command] = {
    "generate": GENERATE,
    "expand": EXPAND,
    "test": TEST,
    "falsify": FALSIFY,
    "whatif": WHATIF,
    "augment": AUGMENT,
    "import": IMPORT,
    "eval": EVAL,
    "eval --fidelity": FIDELITY,
    "runs show": RUNS_SHOW,
    "runs list": RUNS_LIST,
    "assets": ASSETS,
}

PAIRS = [(c, f) for c, row in COMMANDS.items() for f in FAULTS if f in row.faults]


def test_every_entry_is_a_known_fault_and_every_fault_is_used():
    for name, row in COMMANDS.items():
        assert set(row.faults) <= set(FAULTS), (name, set(row.faults) - set(FAULTS))
    assert {f for _, f in PAIRS} == set(FAULTS)


# --- the test ------------------------------------------------------------------------------------


def _snapshot(root: Path) -> dict[str, str]:
    """Every file under ``root``: its path relative to ``root`` -> its sha256 (a symbolic
    link: its target; a file over 1 MB: its size, as the sparse one is)."""
    found = {}
    for p in root.rglob("*"):
        rel = p.relative_to(root).as_posix()
        if p.is_symlink():
            found[rel] = "-> " + os.readlink(p)
        elif p.is_file():
            size = p.stat().st_size
            found[rel] = (f"{size} bytes" if size > 1_000_000
                          else hashlib.sha256(p.read_bytes()).hexdigest())
    return found


def _under(rel: str, areas: list[Path], root: Path) -> bool:
    return any(Path(root, rel).is_relative_to(a) for a in areas)


@pytest.mark.parametrize(("command", "fault"), PAIRS, ids=[f"{c}-{f}" for c, f in PAIRS])
def test_fault(command: str, fault: str, tmp_path: Path, request, monkeypatch) -> None:
    """``command`` given ``fault`` keeps the promises of the module docstring."""
    row = COMMANDS[command]
    for name in row.fixtures:
        request.getfixturevalue(name)
    case = Case(root=tmp_path, request=request)
    case.cwd.mkdir()
    monkeypatch.chdir(case.cwd)  # a command that falls back to the working folder writes here
    args = row.faults[fault](case)
    before = _snapshot(tmp_path)

    res = _cli(*args)

    after = _snapshot(tmp_path)
    refused = FAULTS[fault].refused if case.refused is None else case.refused
    if refused:
        line = _one_line_error(res, *([case.names] if case.names else []))
        says = FAULTS[fault].says
        assert not says or any(w in line.lower() for w in says), (says, line)
        assert res.stderr.strip() == line and not res.stdout.strip(), (res.stdout, res.stderr)
    else:
        assert res.exit_code == 0, (res.exit_code, res.output, res.exception)
        assert "Traceback" not in res.output and "error:" not in res.output, res.output
        assert case.finished is not None, "a finishing entry says what it finished"
        case.finished(res)
    areas = [case.out] + ([] if refused else case.may_write)
    outside = sorted(rel for rel in set(after) - set(before) if not _under(rel, areas, tmp_path))
    assert not outside, f"written outside {[str(a) for a in areas]}: {outside}"
    mine = {rel for rel in before if refused or not (rel in case.own or _under(rel, case.may_write, tmp_path))}
    lost = sorted(rel for rel in mine if rel not in after)
    changed = sorted(rel for rel in mine if rel in after and after[rel] != before[rel])
    assert not lost and not changed, f"removed: {lost}; changed: {changed}"
