"""The report's "Behavior tests" section: what ``regen test`` left in ``RUN/tests/<policy>/``.

``tests.json`` is read as plain JSON, field by field, so that a file from an older or newer
version, or one edited by hand, still shows what it can; a file that cannot be read at all is
named with its problem. Failure pictures are linked only when they lie inside their policy's
folder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.report.links import href, inside_href, num, text
from regen.runfolder import RunFolder, ScenarioFolder, behavior_test_name, read_json, read_tests

__all__ = ["BehaviorTests", "CaseRow", "PolicyTests", "RateRow", "load_tests"]

STATUSES = ("passed", "failed", "skipped")
#: what a scenario's causal check means for a test in it (a failure there may not be the policy's)
CAUSAL_NOTES = {
    "confounded": "another entity alone explains the behavior, so the scenario may test that instead of its cause",
    "not_sufficient": "a reference robot ignores the cause, so the scenario may not call for the behavior",
    "not_necessary": "a reference robot shows the behavior without the cause too",
}
JUNIT = "junit.xml"


@dataclass
class CaseRow:
    """One test (a scenario variant run with the policy)."""

    scenario: str  # scenario folder name
    variant: int
    status: str  # passed, failed, skipped, unknown
    cause: str | None = None  # why it failed ('collision', 'state_not_reached', ...)
    message: str = ""
    collision: bool = False
    collision_with: str | None = None
    min_ttc: float | None = None  # [s]
    min_distance: float | None = None  # [m]
    gif: str | None = None  # href of the failure's GIF, relative to report.html
    anchor: str | None = None  # the scenario's section in the page
    number: int | None = None  # the scenario's number in the page
    cause_label: str = ""  # the scenario's root cause (its folder name when unknown)
    behavior_label: str = ""  # the behavior the scenario explains (the run's when unknown)
    #: why this result may no longer hold: its scenario is gone, or changed since the test ran
    #: (a later ``regen generate --fresh`` or rerun); None: the scenario is the one tested
    stale: str | None = None
    #: the scenario's causal check when the test ran ('caused', 'confounded: traffic_light1');
    #: None: not recorded (no causal part, or a tests.json written before the field existed)
    causal: str | None = None

    @property
    def ran(self) -> bool:
        return self.status in ("passed", "failed")

    @property
    def causal_status(self) -> str:
        """The causal status alone ('confounded'), without the confounders ('' when unknown)."""
        return (self.causal or "").split(":", 1)[0].strip()

    @property
    def causal_label(self) -> str:
        """The causal check for people to read: 'caused', 'confounded by traffic_light1',
        'not sufficient' (entity names kept as written)."""
        status, _, names = (self.causal or "").partition(":")
        label = status.strip().replace("_", " ")
        if names.strip():
            label += (" by " if status.strip() == "confounded" else ": ") + names.strip()
        return label

    @property
    def causal_note(self) -> str:
        """What the causal check means for this test's result ('' when it says nothing)."""
        return CAUSAL_NOTES.get(self.causal_status, "")


@dataclass
class PolicyTests:
    """One ``tests/<folder>/tests.json``."""

    folder: str  # folder name under tests/
    policy: str = ""  # the SPEC given to regen test
    oracle: str = ""
    problem: str | None = None  # why tests.json could not be read (then no cases)
    cases: list[CaseRow] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)  # file name -> href

    def count(self, status: str) -> int:
        return sum(1 for c in self.cases if c.status == status)

    @property
    def ran(self) -> list[CaseRow]:
        return [c for c in self.cases if c.ran]

    @property
    def collisions(self) -> int:
        return sum(1 for c in self.ran if c.collision)

    @property
    def collision_rate(self) -> float | None:
        return self.collisions / len(self.ran) if self.ran else None

    @property
    def min_ttc(self) -> float | None:
        """Smallest time to collision [s] over the tests that ran (None: nothing approached)."""
        return min((c.min_ttc for c in self.ran if c.min_ttc is not None), default=None)

    @property
    def failures(self) -> list[CaseRow]:
        return [c for c in self.cases if c.status == "failed"]

    @property
    def stale(self) -> list[CaseRow]:
        return [c for c in self.cases if c.stale]


@dataclass
class RateRow:
    """Collision rate of each policy over the tests of one behavior or one cause."""

    label: str
    kind: str  # 'behavior' or 'cause'
    anchor: str | None = None  # the (first) scenario section of this cause
    cells: list[tuple[int, int]] = field(default_factory=list)  # (collisions, tests) per policy


@dataclass
class BehaviorTests:
    policies: list[PolicyTests] = field(default_factory=list)
    rates: list[RateRow] = field(default_factory=list)


def _case(raw: dict[str, Any], base: Path, folder: str) -> CaseRow:
    status = raw.get("status")
    variant = raw.get("variant")
    return CaseRow(
        scenario=text(raw.get("scenario")) or "?",
        variant=variant if isinstance(variant, int) and not isinstance(variant, bool) else 0,
        status=status if status in STATUSES else "unknown",
        cause=text(raw.get("cause")) or None, message=text(raw.get("message")),
        collision=raw.get("collision") is True, collision_with=text(raw.get("collision_with")) or None,
        min_ttc=num(raw.get("min_ttc")), min_distance=num(raw.get("min_distance")),
        gif=inside_href(base, raw.get("gif"), RunFolder.TESTS, folder), causal=text(raw.get("causal")) or None)


def read_policy(run_dir: Path, folder: str, loaded) -> PolicyTests:
    """One policy's tests from its :class:`~regen.runfolder.Loaded` tests.json."""
    base = Path(run_dir) / RunFolder.TESTS / folder
    out = PolicyTests(folder=folder, policy=folder)
    out.files = {name: href(RunFolder.TESTS, folder, name)
                 for name in (RunFolder.TESTS_JSON, JUNIT) if (base / name).is_file()}
    if not loaded.ok:
        out.problem = loaded.problem
        return out
    data = loaded.value
    out.policy = text(data.get("policy")) or folder
    out.oracle = text(data.get("oracle"))
    cases = data.get("cases")
    if not isinstance(cases, list):
        out.problem = "unreadable: no list of cases"
        return out
    out.cases = [_case(c, base, folder) for c in cases if isinstance(c, dict)]
    if len(out.cases) < len(cases):
        out.problem = f"{len(cases) - len(out.cases)} case(s) unreadable and left out"
    for c in out.cases:
        c.stale = _stale(Path(run_dir), base, c)
    return out


def _stale(run_dir: Path, base: Path, c: CaseRow) -> str | None:
    """Why ``c``'s result may not hold for the run's scenario as it is now: the scenario folder
    is gone, or its files differ from those the test judged (the digest ``regen test`` kept in
    ``RunFolder.TEST_CASES``). None when it is the same, or nothing was kept to compare."""
    folder = run_dir / RunFolder.SCENARIOS / c.scenario
    if c.scenario in ("", "?") or "/" in c.scenario or "\\" in c.scenario:
        return None
    if not folder.is_dir():
        return "its scenario is no longer in the run"
    kept = read_json(base / RunFolder.TEST_CASES / f"{behavior_test_name(c.scenario, c.variant)}.json")
    digest = kept.value.get("digest") if kept.ok and isinstance(kept.value, dict) else None
    if not isinstance(digest, str):
        return None
    return None if digest == ScenarioFolder(folder).digest() else "its scenario changed since the test ran"


def load_tests(run_dir: Path, scenarios: list, behavior: str) -> BehaviorTests | None:
    """The section's content, or None when the run has no behavior tests. ``scenarios`` are the
    page's :class:`~regen.report.load.ScenarioView` objects (for causes and links)."""
    found = read_tests(run_dir)
    if not found:
        return None
    views = {sv.folder: sv for sv in scenarios}
    if not behavior:  # no run.json: the scenarios carry the behavior too
        behavior = next((sv.scenario.behavior.text for sv in scenarios if sv.scenario), "")
    out = BehaviorTests(policies=[read_policy(run_dir, name, got) for name, got in found.items()])
    behaviors: dict[str, RateRow] = {}  # a folder of hand-written chains explains several
    causes: dict[str, RateRow] = {}
    for pt in out.policies:
        for c in pt.cases:
            sv = views.get(c.scenario)
            if sv is not None:
                c.anchor, c.number = sv.anchor, sv.number
                c.cause_label = sv.chain[0] if sv.chain else sv.folder
            else:
                c.cause_label = c.scenario
            explained = sv.scenario.behavior.text if sv is not None and sv.scenario else ""
            c.behavior_label = explained or behavior or "the run's behavior"
            behaviors.setdefault(c.behavior_label, RateRow(c.behavior_label, "behavior"))
            causes.setdefault(c.cause_label, RateRow(c.cause_label, "cause", c.anchor))
    rows = [*(behaviors.values() or [RateRow(behavior or "the run's behavior", "behavior")]),
            *causes.values()]
    for row in rows:
        for pt in out.policies:
            mine = [c for c in pt.ran
                    if (c.behavior_label if row.kind == "behavior" else c.cause_label) == row.label]
            row.cells.append((sum(1 for c in mine if c.collision), len(mine)))
    out.rates = rows
    return out
