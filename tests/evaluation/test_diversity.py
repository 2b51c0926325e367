"""Diversity metrics on hand-computable inputs, and the sampling protocol."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from regen.errors import ConfigError
from regen.evaluation.diversity import (
    compare_sets,
    embedding_diversity,
    embedding_diversity_of_vectors,
    sample_indices,
    self_bleu,
    self_bleu_diversity,
    tokenize,
)

UNRELATED = [
    "The ego vehicle brakes because a pedestrian crosses the road.",
    "Quarterly earnings of the bank rose by four percent.",
    "Add two cups of flour and bake the cake for forty minutes.",
    "The violin concerto was composed in the eighteenth century.",
]


def test_tokenize_splits_punctuation_and_lowercases():
    assert tokenize("The Ego stops, abruptly.") == ["the", "ego", "stops", ",", "abruptly", "."]


def test_vector_diversity_matches_hand_computation():
    v = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])  # pair cosines: 0, 1/sqrt2, 1/sqrt2
    expected = 1.0 - (0.0 + 2 / math.sqrt(2)) / 3
    assert embedding_diversity_of_vectors(v) == pytest.approx(expected)
    assert embedding_diversity_of_vectors(np.ones((5, 3))) == pytest.approx(0.0)
    with pytest.raises(ConfigError):
        embedding_diversity_of_vectors(np.ones((1, 3)))


def test_identical_sentences_have_zero_diversity(encoder):
    same = ["An ambulance approaches from behind with its siren on."] * 4
    assert embedding_diversity(same, encoder) == pytest.approx(0.0, abs=1e-5)
    assert self_bleu_diversity(same) == pytest.approx(0.0, abs=1e-12)


def test_unrelated_sentences_are_diverse_and_paraphrases_are_not(encoder):
    paraphrases = [
        "The car stops suddenly because a pedestrian steps onto the road.",
        "The vehicle brakes hard since a person walks into the street.",
        "A pedestrian enters the road, so the car comes to an abrupt stop.",
        "The auto halts abruptly as someone crosses in front of it.",
    ]
    unrelated = embedding_diversity(UNRELATED, encoder)
    para = embedding_diversity(paraphrases, encoder)
    assert unrelated > 0.8
    assert para < 0.6
    assert unrelated - para > 0.3


def _direct_bleu4(hyp: list[str], refs: list[list[str]]) -> float:
    """BLEU-4 with uniform weights and epsilon-0.1 smoothing of zero counts (method1)."""
    logs = []
    for n in range(1, 5):
        h = Counter(tuple(hyp[i:i + n]) for i in range(len(hyp) - n + 1))
        max_ref: Counter = Counter()
        for r in refs:
            for g, c in Counter(tuple(r[i:i + n]) for i in range(len(r) - n + 1)).items():
                max_ref[g] = max(max_ref[g], c)
        clipped = sum(min(c, max_ref[g]) for g, c in h.items())
        total = sum(h.values())
        logs.append(math.log((clipped if clipped else 0.1) / total))
    c = len(hyp)
    r = min((len(x) for x in refs), key=lambda L: (abs(L - c), L))
    bp = 1.0 if c > r else math.exp(1 - r / c)
    return bp * math.exp(sum(logs) / 4)


def test_self_bleu_matches_direct_computation():
    texts = [
        "the ego vehicle stops because a pedestrian crosses the road",
        "the ego vehicle stops because a cyclist crosses the road ahead",
        "an ambulance approaches from behind and the ego vehicle yields",
        "the traffic light turns red and the ego vehicle stops",
    ]
    toks = [t.split() for t in texts]
    direct = np.mean([_direct_bleu4(h, [t for j, t in enumerate(toks) if j != i])
                      for i, h in enumerate(toks)])
    assert self_bleu(texts) == pytest.approx(direct, rel=1e-9)
    assert 0.0 < self_bleu(texts) < 1.0
    # sentences sharing no token at all score ~0 Self-BLEU, i.e. diversity ~1
    assert self_bleu_diversity(["aa bb cc dd", "ee ff gg hh", "ii jj kk ll"]) > 0.99


def test_self_bleu_needs_two_texts():
    with pytest.raises(ConfigError):
        self_bleu(["only one"])


def test_sampling_is_deterministic_under_a_seed():
    a = sample_indices(30, 10, 10, seed=7, name="zero-shot")
    b = sample_indices(30, 10, 10, seed=7, name="zero-shot")
    c = sample_indices(30, 10, 10, seed=8, name="zero-shot")
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))
    assert all(len(set(x.tolist())) == 10 and x.max() < 30 for x in a)  # no replacement
    assert all(np.array_equal(x, np.arange(5)) for x in sample_indices(5, 5, 3, 0, "all"))


def _sets():
    big = [f"scenario {i} with cause number {i % 7} and entity {i % 3}" for i in range(30)]
    small = [f"the ego vehicle stops for reason {i}" for i in range(12)]
    other = UNRELATED * 4
    return {"big": big, "small": small, "other": other}


def test_compare_sets_protocol(fake_encoder):
    res1 = compare_sets(_sets(), repeats=10, seed=3, encoder=fake_encoder)
    res2 = compare_sets(_sets(), repeats=10, seed=3, encoder=fake_encoder)
    assert [r.model_dump() for r in res1] == [r.model_dump() for r in res2]
    by = {r.name: r for r in res1}
    assert {r.sample_size for r in res1} == {12}  # n = smallest set size
    assert by["small"].embedding_diversity.std == pytest.approx(0.0)  # always the whole set
    assert by["big"].embedding_diversity.std > 0  # subsets differ across draws
    assert len(by["big"].self_bleu_diversity.values) == 10
    # each value is the metric of one draw: recompute the first draw directly
    draw = sample_indices(30, 12, 10, 3, "big")[0]
    texts = [_sets()["big"][i] for i in draw]
    assert by["big"].self_bleu_diversity.values[0] == pytest.approx(self_bleu_diversity(texts))
    # a set's figures do not depend on which other sets are compared (same n)
    alone = compare_sets({"big": _sets()["big"], "small": _sets()["small"]}, repeats=10,
                         seed=3, encoder=fake_encoder)
    assert alone[0].model_dump() == by["big"].model_dump()


def test_compare_sets_rejects_tiny_sets(fake_encoder):
    with pytest.raises(ConfigError, match="at least two"):
        compare_sets({"a": ["one"], "b": ["x y", "z w"]}, encoder=fake_encoder)
    with pytest.raises(ConfigError):
        compare_sets({}, encoder=fake_encoder)
