"""Pairwise cause difference and text diversity of scenarios."""

from __future__ import annotations

import pytest

from regen.evaluation.controllability import (
    DIFFERENT_CAUSE,
    SAME_CAUSE,
    cause_difference,
    controllability,
)
from regen.evaluation.runs import ScenarioRecord


def rec(sid, causes, text, behavior="stop"):
    return ScenarioRecord(id=sid, behavior=behavior, causes=causes, text=text)


def test_cause_difference_is_one_minus_jaccard():
    assert cause_difference(["a"], ["a"]) == 0.0
    assert cause_difference(["a"], ["b"]) == 1.0
    assert cause_difference(["a", "b"], ["b", "c"]) == pytest.approx(1 - 1 / 3)
    assert cause_difference(["An  Ambulance"], ["an ambulance"]) == 0.0
    assert cause_difference([], []) == 0.0


def test_groups_and_shares(fake_encoder):
    scen = [
        rec("a1", ["ambulance behind"], "ambulance behind in the left lane siren on"),
        rec("a2", ["ambulance behind"], "ambulance behind in the right lane siren on"),
        rec("j1", ["jaywalker"], "a jaywalker crosses between parked cars at night"),
        rec("d1", ["debris"], "debris falls from a truck onto the highway"),
        rec("x1", ["jaywalker"], "", behavior="stop"),  # no text: skipped
        rec("o1", ["pet outside"], "let the pet in", behavior="open door"),  # alone in its behavior
    ]
    rep = controllability(scen, fake_encoder)
    assert len(rep.pairs) == 6  # C(4, 2) within 'stop'; 'open door' has one scenario
    same = rep.groups[SAME_CAUSE]
    diff = rep.groups[DIFFERENT_CAUSE]
    assert (same.pairs, diff.pairs) == (1, 5)
    assert same.share == pytest.approx(1 / 6) and diff.share == pytest.approx(5 / 6)
    # property variations read alike, new causes read differently
    assert same.diversity_mean < diff.diversity_mean
    pair = next(p for p in rep.pairs if {p.a, p.b} == {"a1", "a2"})
    assert pair.group == SAME_CAUSE and pair.cause_difference == 0.0
    assert rep.correlation is not None and rep.correlation > 0


def test_without_embeddings_only_shares():
    scen = [rec("a", ["x"], "t1"), rec("b", ["y"], "t2"), rec("c", ["x"], "t3")]
    rep = controllability(scen, embeddings=False)
    assert all(p.diversity is None for p in rep.pairs)
    assert rep.groups[SAME_CAUSE].pairs == 1 and rep.groups[SAME_CAUSE].diversity_mean is None
