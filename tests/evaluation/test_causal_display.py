"""The causal check (does the cause cause the behavior?) beside the verdict status in the
terminal: ``regen generate``'s lines, ``regen runs show`` and ``regen runs list``, and in the
evaluation's run records. A verdict.json from before the check shows 'not checked' or nothing."""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console
from typer.testing import CliRunner

from regen.cli import app
from regen.core.behavior import Behavior
from regen.core.io import write_json
from regen.core.verdict import Causal, ReferenceRun, Verdict
from regen.evaluation.runs import causal_counts, load_run
from regen.pipeline.stages import ScenarioOutcome
from regen.pipeline.terminal import causal_mark, print_outcomes

STOP = "the ego-vehicle stops abruptly"
CONFOUNDED_WHY = "traffic_light1 alone makes the reference driver stop, without car1"
IGNORED_WHY = "with car1, the reference driver does not stop: drove on"


def _verdict(causal: Causal | None = None, *, ok: bool = True) -> Verdict:
    return Verdict(feasible=ok, status="verified" if ok else "fsm_incomplete",
                   reason="all 2 stages reached in order" if ok else "stage 2 never held", causal=causal)


def _caused() -> Causal:
    return Causal(status="caused", reason="the reference driver stopped; with car1 removed it does not",
                  with_cause=ReferenceRun(shown=True), without_cause=ReferenceRun(shown=False))


def _confounded() -> Causal:
    return Causal(status="confounded", reason=CONFOUNDED_WHY, confounders=["traffic_light1"])


def _not_sufficient() -> Causal:
    return Causal(status="not_sufficient", reason=IGNORED_WHY)


# --- regen generate's terminal lines ----------------------------------------------------------


def _printed(outcomes: list[ScenarioOutcome], tmp_path: Path) -> list[str]:
    console = Console(record=True, width=300, color_system=None)
    print_outcomes(console, outcomes, tmp_path)
    return console.export_text().splitlines()


def test_generate_lines_show_the_causal_part_after_the_status(tmp_path: Path) -> None:
    lines = _printed([ScenarioOutcome("01-a", _verdict(_caused())),
                      ScenarioOutcome("02-b", _verdict(_confounded())),
                      ScenarioOutcome("03-c", _verdict(_not_sufficient())),
                      ScenarioOutcome("04-d", _verdict())], tmp_path)
    assert lines[0] == "  01-a: verified, caused: all 2 stages reached in order"  # no second line
    assert lines[1] == "  02-b: verified, confounded (traffic_light1): all 2 stages reached in order"
    assert lines[2] == f"      cause: {CONFOUNDED_WHY}"
    assert lines[3] == "  03-c: verified, not_sufficient: all 2 stages reached in order"
    assert lines[4] == f"      cause: {IGNORED_WHY}"
    assert lines[5] == "  04-d: verified: all 2 stages reached in order"  # an older verdict: as before
    assert len(lines) == 6


def test_generate_colours_the_causal_part() -> None:
    assert causal_mark(None) == ""
    assert causal_mark(_caused()) == "[green]caused[/]"
    assert causal_mark(_confounded()) == "[yellow]confounded (traffic_light1)[/]"
    assert causal_mark(_not_sufficient()) == "[yellow]not_sufficient[/]"
    assert causal_mark(Causal(status="not_checked", reason="no reference driver")).startswith("[dim]")


# --- run folders -------------------------------------------------------------------------------


def _run(root: Path, verdicts: dict[str, Verdict | str | dict | None], name: str = "run") -> Path:
    run = root / name
    for folder, v in verdicts.items():
        d = run / "scenarios" / folder
        d.mkdir(parents=True)
        if isinstance(v, str):
            (d / "verdict.json").write_text(v)
        elif v is not None:
            write_json(d / "verdict.json", v)
    (run / "run.json").write_text(json.dumps({
        "behavior": Behavior(text=STOP, domain="driving").model_dump(mode="json"), "settings": {},
        "status": "done", "started": "2025-01-02T10:00:00+00:00", "scenarios": list(verdicts)}))
    return run


def _verdicts() -> dict[str, Verdict | str | dict | None]:
    return {"01-caused": _verdict(_caused()), "02-confounded": _verdict(_confounded()),
            "03-old": _verdict(), "04-unfinished": None,
            # a verdict that does not validate, with a causal part read loosely
            "05-loose": {"feasible": True, "status": "verified", "reason": "ok", "stages": "oops",
                         "causal": {"status": "confounded", "reason": "a dog", "confounders": ["dog1"]}}}


def test_records_carry_the_causal_part(tmp_path: Path) -> None:
    run = load_run(_run(tmp_path, _verdicts()))
    by = {s.id: s for s in run.scenarios}
    assert (by["01-caused"].status, by["01-caused"].causal) == ("verified", "caused")
    assert by["02-confounded"].causal == "confounded: traffic_light1"
    assert by["02-confounded"].causal_reason == CONFOUNDED_WHY
    assert by["03-old"].causal is None and by["04-unfinished"].causal is None
    assert (by["05-loose"].status, by["05-loose"].causal) == ("verified", "confounded: dog1")


def test_causal_counts_of_a_run(tmp_path: Path) -> None:
    run = _run(tmp_path, {**_verdicts(), "06-broken": "{nope"})
    assert causal_counts(run) == {"caused": 1, "confounded": 2}
    assert causal_counts(_run(tmp_path, {"01-old": _verdict()}, name="old")) == {}


def _cli(*args: str) -> str:
    res = CliRunner().invoke(app, list(args), env={"COLUMNS": "300"})
    assert res.exit_code == 0, (res.output, res.exception)
    return res.output


def test_runs_show_has_a_causal_column_and_counts_the_caused(tmp_path: Path) -> None:
    out = _cli("runs", "show", str(_run(tmp_path, _verdicts())))
    header = next(line for line in out.splitlines() if "scenario" in line and "verdict" in line)
    assert header.index("verdict") < header.index("causal") < header.index("reason")
    row = {line.split("│")[1].strip(): line for line in out.splitlines() if line.count("│") >= 4}
    assert "caused" in row["01-caused"] and "verified" in row["01-caused"]
    assert "confounded: traffic_light1" in row["02-confounded"] and "verified" in row["02-confounded"]
    assert "not checked" in row["03-old"] and "verified" in row["03-old"]
    assert f"cause: {CONFOUNDED_WHY}" in out  # the causal reason under the verdict's
    assert "cause: the reference driver stopped" not in out  # not for a caused one
    assert "caused: 1/2 scenarios checked" in out


def test_runs_show_without_any_causal_check_counts_nothing(tmp_path: Path) -> None:
    out = _cli("runs", "show", str(_run(tmp_path, {"01-old": _verdict()})))
    assert "not checked" in out and "caused:" not in out


def test_runs_list_counts_the_caused(tmp_path: Path) -> None:
    _run(tmp_path, {"01-caused": _verdict(_caused()), "02-confounded": _verdict(_confounded()),
                    "03-caused": _verdict(_caused())}, name="checked")
    _run(tmp_path, {"01-old": _verdict()}, name="old")
    out = _cli("runs", "list", str(tmp_path))
    header = [c.strip() for c in next(line for line in out.splitlines() if "folder" in line).split("┃")]
    column = header.index("caused")
    assert header.index("feasible") < column < header.index("started")
    rows = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")]
            for line in out.splitlines() if line.count("│") >= 6}
    assert rows["checked"][column] == "2/3"  # caused / checked
    assert rows["old"][column] == "—"  # no verdict has a causal part
