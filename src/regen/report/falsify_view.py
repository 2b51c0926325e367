"""The report's "Falsification" section: what ``regen falsify`` left in ``RUN/falsify/<policy>/``.

``falsify.json`` is read as plain JSON (:func:`regen.runfolder.read_falsify`), field by field, so a
file from another version or edited by hand still shows what it can; one that cannot be read is
named with its problem. A failure's picture is linked only when it lies inside its policy's folder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.report.links import href, inside_href, num, text
from regen.runfolder import RunFolder, read_falsify

__all__ = ["FalsifyFinding", "PolicyFalsification", "load_falsify"]


@dataclass
class FalsifyFinding:
    """One minimal failing set of edits."""

    cid: str
    scenario: str  # the source scenario's folder name
    edits: list[str] = field(default_factory=list)  # in words
    failure: str = ""  # the collision or missed state, in words
    scripted: str = ""  # the scripted robot's verdict (and causal check)
    minimal: bool = False
    by_model: bool = False
    replay: str = ""  # the regen test command
    gif: str | None = None  # href of the failure's picture
    tests: str | None = None  # href of the candidate's tests.json
    xosc: str | None = None  # href of its OpenSCENARIO file
    anchor: str | None = None  # the source scenario's section in the page
    number: int | None = None
    min_ttc: float | None = None  # [s]


@dataclass
class PolicyFalsification:
    """One ``falsify/<folder>/falsify.json``."""

    folder: str
    policy: str = ""
    oracle: str = ""  # the tests' oracle (fsm, safety)
    problem: str | None = None  # why falsify.json could not be read
    status: str = ""  # done, interrupted, running
    budget: int | None = None
    tried: int = 0
    simulated: int = 0  # what the budget counts
    invalid: int = 0  # simulated ones in which the scripted robot did not verify or collided
    ungrounded: int = 0  # candidates that could not be grounded (not simulated, not counted)
    failures: int = 0
    errors: int = 0
    wall: float | None = None  # [s]
    parameter_search: str = ""
    findings: list[FalsifyFinding] = field(default_factory=list)
    file: str | None = None  # href of falsify.json


def _int(value: Any) -> int:
    return value if isinstance(value, int) and not isinstance(value, bool) else 0


def _finding(raw: dict[str, Any], candidates: dict[str, dict[str, Any]], base: Path, folder: str,
             anchors: dict[str, tuple[str, int]]) -> FalsifyFinding:
    cid = text(raw.get("cid")) or "?"
    cand = candidates.get(cid, {})
    policy = cand.get("policy") if isinstance(cand.get("policy"), dict) else {}
    scripted = raw.get("scripted") if isinstance(raw.get("scripted"), dict) else {}
    words = raw.get("edits")
    status = text(scripted.get("status"))
    causal = text(scripted.get("causal"))

    def inside(value: Any) -> str | None:  # a file of the policy's folder, linked
        return inside_href(base, value, RunFolder.FALSIFY, folder)

    out = FalsifyFinding(cid=cid, scenario=text(raw.get("scenario")) or "?",
                         edits=[str(w) for w in words] if isinstance(words, list) else [],
                         failure=text(raw.get("failure")), scripted=status + (f", {causal}" if causal else ""),
                         minimal=raw.get("minimal") is True, by_model=raw.get("by_model") is True,
                         replay=text(raw.get("replay")), gif=inside(policy.get("gif")),
                         tests=inside(cand.get("tests")), xosc=inside(cand.get("xosc")),
                         min_ttc=num(policy.get("min_ttc")))
    out.anchor, out.number = anchors.get(out.scenario, (None, None))
    return out


def read_policy(run_dir: Path, folder: str, loaded, anchors: dict[str, tuple[str, int]]) -> PolicyFalsification:
    """One policy's search from its :class:`~regen.runfolder.Loaded` falsify.json."""
    base = Path(run_dir) / RunFolder.FALSIFY / folder
    out = PolicyFalsification(folder=folder, policy=folder)
    if (base / RunFolder.FALSIFY_JSON).is_file():
        out.file = href(RunFolder.FALSIFY, folder, RunFolder.FALSIFY_JSON)
    if not loaded.ok:
        out.problem = loaded.problem
        return out
    data = loaded.value
    out.policy = text(data.get("policy")) or folder
    settings = data.get("settings") if isinstance(data.get("settings"), dict) else {}
    out.oracle = text(settings.get("oracle"))
    out.status = text(data.get("status"))
    out.budget = _int(data.get("budget")) or None
    out.tried = _int(data.get("tried"))
    out.simulated = _int(data.get("simulated")) if "simulated" in data else out.tried
    out.ungrounded = max(0, out.tried - out.simulated)
    out.invalid = max(0, _int(data.get("invalid")) - out.ungrounded)
    out.failures, out.errors = _int(data.get("failures")), _int(data.get("errors"))
    out.wall = num(data.get("wall"))
    out.parameter_search = text(data.get("parameter_search"))
    cands = data.get("candidates") if isinstance(data.get("candidates"), list) else []
    by_cid = {c["cid"]: c for c in cands if isinstance(c, dict) and isinstance(c.get("cid"), str)}
    findings = data.get("findings")
    if not isinstance(findings, list):
        out.problem = "unreadable: no list of findings"
        return out
    out.findings = [_finding(f, by_cid, base, folder, anchors) for f in findings if isinstance(f, dict)]
    if len(out.findings) < len(findings):
        out.problem = f"{len(findings) - len(out.findings)} finding(s) unreadable and left out"
    return out


def load_falsify(run_dir: Path, anchors: dict[str, tuple[str, int]]) -> list[PolicyFalsification]:
    """Every ``RUN/falsify/*/falsify.json``; ``anchors``: scenario folder name -> (its section id,
    its number in the page)."""
    return [read_policy(run_dir, name, got, anchors) for name, got in read_falsify(run_dir).items()]
