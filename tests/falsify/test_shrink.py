"""Shrinking a failing set of edits to the fewest that still fail, against a fake oracle."""

from __future__ import annotations

import itertools

from regen.falsify.shrink import shrink


def oracle(fails, unknown=frozenset()):
    """An outcome function: 'failed' for the sets ``fails`` says, None for ``unknown`` ones;
    it records what it was asked."""
    asked: list[tuple] = []

    def outcome(edits: tuple) -> str | None:
        asked.append(edits)
        if frozenset(edits) in unknown:
            return None
        return "failed" if fails(frozenset(edits)) else "passed"

    outcome.asked = asked
    return outcome


def test_a_failing_triple_shrinks_to_the_pair_that_fails():
    out = oracle(lambda s: {"a", "c"} <= s)
    got = shrink(("a", "b", "c"), out)
    assert set(got.edits) == {"a", "c"} and got.minimal
    assert got.chain[0] == ("a", "b", "c") and set(got.chain[-1]) == {"a", "c"}
    assert len(out.asked) == len(set(out.asked))  # every subset asked once


def test_a_single_failing_edit_is_found_inside_a_larger_set():
    got = shrink(("a", "b", "c", "d"), oracle(lambda s: "d" in s))
    assert got.edits == ("d",) and got.minimal
    assert [len(c) for c in got.chain] == [4, 3, 2, 1]


def test_no_failing_subset_means_the_set_is_minimal():
    got = shrink(("a", "b"), oracle(lambda s: s == {"a", "b"}))
    assert got.edits == ("a", "b") and got.minimal and got.chain == [("a", "b")]
    single = shrink(("a",), oracle(lambda s: True))
    assert single.edits == ("a",) and single.minimal and single.chain == [("a",)]


def test_interacting_edits_are_found_below_the_one_smaller_subsets():
    # only the whole set and {a} fail: no one-smaller subset does, the single does
    out = oracle(lambda s: s == {"a", "b", "c"} or s == {"a"})
    got = shrink(("a", "b", "c"), out)
    assert got.edits == ("a",) and got.minimal


def test_a_subset_not_tried_within_the_budget_leaves_it_not_minimal():
    unknown = {frozenset(s) for s in itertools.combinations("ab", 1)}
    got = shrink(("a", "b"), oracle(lambda s: s == {"a", "b"}, unknown=unknown))
    assert got.edits == ("a", "b") and not got.minimal


def test_invalid_subsets_are_not_failures():
    def outcome(edits):
        return "failed" if len(edits) == 2 else "invalid"

    got = shrink(("a", "b"), outcome)
    assert got.edits == ("a", "b") and got.minimal
