"""The yes/no fidelity judge on its labeled set: precision, recall and accuracy per split.

    python benchmarks/fidelity_judge.py [--llm local] [--split tune|test|all] [--cache PATH] [--record PATH] [-v]

Runs :func:`regen.verify.fidelity.ask_model`, the call the pipeline makes at grounding when
the rules cannot decide, on every case of ``regen/manipulation/data/judge.jsonl``:
a cause text that names no asset of the database, and the scene as grounding built it. "Yes"
(the scene shows the cause) is the positive class: precision is the share of "yes" answers
that were right (a scene that does not show its cause called shown lowers it), recall the share
of scenes that show their cause called shown. A second line per split gives the decision the
pipeline records: the rules where they decide (a scene of only the robot's task objects), else
the judge. Tune prompts on ``--split tune`` only; ``test`` is measured once, at the end.
Without ``--cache`` answers live in memory, so every call reaches the model and the wall time is
real. ``--record`` writes this run's answers as a cassette: after a change to the judge's prompt,
re-record ``tests/data/cassettes/fidelity_judge_manipulation.json`` (``--split all``), which
``tests/verify/test_fidelity_judge.py`` replays.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from importlib import resources
from typing import Literal

from pydantic import Field

from regen import domains
from regen.core.base import Model
from regen.core.behavior import Behavior
from regen.core.scenario import FSM, Entity, Scenario
from regen.llm import LLM
from regen.verify.fidelity import ask_model, check_rules

DATA = ("regen.manipulation", "data/judge.jsonl")


class JudgeCase(Model):
    """One labeled scene: the robot's task, the cause text, the entities grounding placed and
    whether they show the cause (``kind``: shown, wrong_state, related, unrelated, own_only)."""

    id: str
    domain: str
    behavior: str
    reward: str | None = None
    cause: str = Field(min_length=1)
    entities: list[Entity] = Field(min_length=1)
    expected: Literal["yes", "no"]
    kind: str
    note: str = ""
    split: Literal["tune", "test"]

    def scenario(self) -> Scenario:
        behavior = Behavior(text=self.behavior, domain=self.domain,
                            params={"reward": self.reward} if self.reward else {})
        return Scenario(id=self.id, domain=self.domain, behavior=behavior, causal_graph=[self.cause, self.behavior],
                        narrative="", entities=self.entities, fsm=FSM())


def load_cases() -> list[JudgeCase]:
    text = resources.files(DATA[0]).joinpath(DATA[1]).read_text(encoding="utf-8")
    return [JudgeCase.model_validate(json.loads(line)) for line in text.splitlines() if line.strip()]


@dataclass
class Counts:
    tp: int = 0
    fp: int = 0
    tn: int = 0
    fn: int = 0

    def add(self, expected: bool, said: bool) -> None:
        if said:
            self.tp, self.fp = self.tp + expected, self.fp + (not expected)
        else:
            self.fn, self.tn = self.fn + expected, self.tn + (not expected)

    def line(self) -> str:
        n = self.tp + self.fp + self.tn + self.fn
        precision = self.tp / (self.tp + self.fp) if self.tp + self.fp else float("nan")
        recall = self.tp / (self.tp + self.fn) if self.tp + self.fn else float("nan")
        return (f"precision {precision:.2f}, recall {recall:.2f}, accuracy {(self.tp + self.tn) / n:.2f} "
                f"(n={n}: tp {self.tp}, fp {self.fp}, tn {self.tn}, fn {self.fn})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", default="local", help="provider name (default: local, the offline model)")
    ap.add_argument("--split", choices=("tune", "test", "all"), default="all")
    ap.add_argument("--cache", default=None, help="an LLM cache file to reuse (default: in memory)")
    ap.add_argument("--record", default=None, help="write the cache's answers to a JSON cassette (without --cache: this run's)")
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per case")
    args = ap.parse_args()
    cases = [c for c in load_cases() if args.split in ("all", c.split)]
    llm = LLM(args.llm, cache=args.cache)
    judge: dict[str, Counts] = {}
    pipeline: dict[str, Counts] = {}
    t0 = time.perf_counter()
    for case in cases:
        backend = domains.make(case.domain)
        scenario = case.scenario()
        robot = backend.report_hints.robot
        got = ask_model(scenario, llm, robot=robot)
        rules = check_rules(scenario, backend.database(), robot=(robot, *backend.wording.robot_names),
                            own=backend.own_objects(scenario.behavior))
        decided = got if rules.status == "undecided" else rules
        expected = case.expected == "yes"
        judge.setdefault(case.split, Counts()).add(expected, got.status == "faithful")
        pipeline.setdefault(case.split, Counts()).add(expected, decided.status == "faithful")
        if args.verbose:
            said = "yes" if got.status == "faithful" else "no"
            mark = "  " if said == case.expected else "XX"
            print(f"{mark} {case.id} {case.split:<4} {case.kind:<11} expected {case.expected:<3} judge {said:<3} "
                  f"rules {rules.status:<10} | {got.reason}")
    wall = time.perf_counter() - t0
    for split in ("tune", "test"):
        if split in judge:
            print(f"{split} judge:    {judge[split].line()}")
            print(f"{split} pipeline: {pipeline[split].line()}")
    t = llm.stats.total
    if args.record:
        llm.cache.export_json(args.record)
    print(f"{len(cases)} cases, {t.model_calls} model calls ({t.input_tokens} tokens in, {t.output_tokens} out), "
          f"{wall:.1f} s wall, llm {args.llm}")


if __name__ == "__main__":
    main()
