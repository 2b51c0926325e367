"""What ``regen falsify`` writes: one :class:`CandidateRecord` per candidate
(``OUT/candidates/<cid>/candidate.json``) and the whole search, :class:`Falsification`
(``OUT/falsify.json``), whose :class:`Finding` list is what a safety engineer acts on."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from regen.core.base import Model
from regen.runfolder import RunFolder
from regen.whatif import Edit

FALSIFY_JSON = RunFolder.FALSIFY_JSON
CANDIDATE_JSON = "candidate.json"
CANDIDATES = "candidates"

#: 'failed': the policy failed where the scripted robot verified and collided with nothing (a
#: failure of the policy); 'passed'; 'invalid': the scripted robot did not verify or collided,
#: or the edits do not apply (the candidate tests nothing); 'error': it could not be run.
Status = Literal["passed", "failed", "invalid", "error"]
#: Where a candidate came from: the single edits, the model's causes (``--llm``), pairs of
#: singles, or a subset tried while shrinking a failing candidate.
Origin = Literal["baseline", "single", "model", "pair", "shrink"]


class ScriptedRun(Model):
    """The scripted robot in the candidate's world (the main job's verdict and causal check)."""

    status: str  # the verdict's status, or 'not_applied' (the edits do not apply)
    verified: bool = False
    causal: str | None = None  # the causal check's status ('caused', ...), None: none
    collision: bool = False  # the scripted robot collided (then the candidate is invalid)
    reason: str = ""


class PolicyRun(Model):
    """The policy in the candidate's world: its test case as ``regen test`` wrote it."""

    status: str  # 'passed', 'failed', 'skipped'
    cause: str | None = None  # 'collision', 'state_not_reached', an incident's kind, ...
    message: str = ""
    collision: bool = False
    collision_with: str | None = None
    collision_time: float | None = None  # [s]
    min_ttc: float | None = None  # [s]
    min_distance: float | None = None  # [m]
    infractions: list[str] = Field(default_factory=list)
    missed: list[str] = Field(default_factory=list)  # the first FSM stage it did not reach
    gif: str | None = None  # the failure's picture, relative to OUT


class CandidateRecord(Model):
    """One candidate: a source scenario with a set of edits, grounded, simulated and tested."""

    cid: str
    scenario: str  # the source scenario's folder name in the run
    edits: list[Edit]
    words: list[str]  # Edit.describe() of each
    origin: Origin = "single"
    by_model: bool = False  # an edit is a cause the model proposed
    status: Status
    reason: str = ""
    scripted: ScriptedRun
    policy: PolicyRun | None = None  # None: the policy did not run (invalid before it)
    parameters: dict[str, dict[str, float]] = Field(default_factory=dict)  # per actor
    folder: str = ""  # the candidate's run folder, relative to OUT
    scenario_folder: str = ""  # its scenario folder, relative to OUT
    tests: str | None = None  # its tests.json, relative to OUT
    xosc: str | None = None  # the OpenSCENARIO file the domain exported, relative to OUT
    wall: float = 0.0  # [s] grounding, simulation and the policy's test
    #: the scripted robot was simulated (False: the edits did not apply or the scenario could not
    #: be grounded, which costs no simulation and does not count against the budget)
    simulated: bool = True
    digest: str = ""  # the scenario folder's digest when tested (resume)
    settings: dict[str, Any] = Field(default_factory=dict)  # what it was tested with (resume)
    kept: bool = False  # finished by an earlier run of the same command
    minimal: bool | None = None  # a failing candidate: no proper subset of its edits fails
    chain: list[str] = Field(default_factory=list)  # a failing one: cids from it to its minimal subset

    @property
    def size(self) -> int:
        return len(self.edits)


class Finding(Model):
    """A minimal failing candidate: the edits that make the policy fail, and how to see it again."""

    cid: str
    scenario: str
    edits: list[str]  # in words
    edit_list: list[Edit]
    minimal: bool
    chain: list[list[str]] = Field(default_factory=list)  # the failing edit sets shrunk through, in words
    by_model: bool = False
    scripted: ScriptedRun
    policy: PolicyRun
    failure: str  # the collision or the missed state, in words
    parameters: dict[str, dict[str, float]] = Field(default_factory=dict)
    folder: str  # the candidate's run folder (absolute)
    gif: str | None = None  # absolute
    xosc: str | None = None  # absolute
    tests: str | None = None  # absolute
    replay: str  # the exact regen test command
    parameter_search: dict[str, Any] | None = None  # regen.falsify.params' answer


class ModelRound(Model):
    """The causes the model proposed (``--llm``), per source scenario."""

    scenario: str
    call_id: str | None = None
    causes: list[str] = Field(default_factory=list)  # accepted: they name an asset
    rejected: dict[str, str] = Field(default_factory=dict)  # text -> why


class Falsification(Model):
    """``OUT/falsify.json``."""

    run: str  # the run folder (absolute)
    out: str = ""  # this search's folder (absolute)
    domain: str
    robot: str
    policy: str
    settings: dict[str, Any]
    budget: int  # candidates grounded and simulated at most
    status: Literal["running", "done", "interrupted"] = "running"
    sources: list[dict[str, Any]] = Field(default_factory=list)  # the verified scenarios searched
    tried: int = 0  # candidates run or kept
    simulated: int = 0  # of which simulated: what the budget counts
    kept: int = 0  # of which finished by an earlier run
    invalid: int = 0
    errors: int = 0
    failures: int = 0  # failing candidates (minimal or not)
    findings: list[Finding] = Field(default_factory=list)
    candidates: list[CandidateRecord] = Field(default_factory=list)
    model: list[ModelRound] = Field(default_factory=list)
    parameter_search: str = ""  # whether the parameter stage ran, and why not
    wall: float = 0.0  # [s] this invocation, in all
    timings: dict[str, float] = Field(default_factory=dict)  # [s] 'search' (edits), 'parameters'
    started: str = ""
    finished: str | None = None


__all__ = ["CANDIDATES", "CANDIDATE_JSON", "FALSIFY_JSON", "CandidateRecord", "Falsification", "Finding",
           "ModelRound", "Origin", "PolicyRun", "ScriptedRun", "Status"]
