"""BLEU-4 without nltk gives nltk's very figure (sentence_bleu, uniform weights, method1)."""

from __future__ import annotations

import random

import pytest

from regen.evaluation.bleu import sentence_bleu4
from regen.evaluation.diversity import self_bleu, tokenize

nltk_bleu = pytest.importorskip("nltk.translate.bleu_score")

WORDS = "the ego vehicle stops a pedestrian crosses road red light cyclist ahead , .".split()


def _nltk(refs, hyp):
    return nltk_bleu.sentence_bleu(refs, hyp, weights=(0.25,) * 4,
                                   smoothing_function=nltk_bleu.SmoothingFunction().method1)


def _text(rng: random.Random) -> list[str]:
    # short texts from a small vocabulary: every case shows up (no 4-gram match, no unigram
    # match, hypotheses shorter than 4 tokens, empty ones, ties between reference lengths)
    return [rng.choice(WORDS[: rng.randint(2, len(WORDS))]) for _ in range(rng.randint(0, 14))]


def test_equals_nltk_float_for_float():
    rng = random.Random(7)
    cases = 0
    for _ in range(2000):
        refs = [_text(rng) for _ in range(rng.randint(1, 4))]
        hyp = _text(rng)
        ours = sentence_bleu4(refs, hyp)
        assert ours == _nltk(refs, hyp), (refs, hyp)
        cases += 0.0 < ours < 1.0
    assert cases > 500  # most cases are neither 0 nor 1: the formula is exercised, not its edges


def test_edges_equal_nltk():
    ref = "the ego vehicle stops at the red light".split()
    for hyp in ([], ["cyclist"], ref, ref[:3], ref + ref, ["the"] * 12):
        assert sentence_bleu4([ref], hyp) == _nltk([ref], hyp)
    assert sentence_bleu4([ref], ref) == 1.0
    assert sentence_bleu4([ref], ["cyclist"]) == 0.0  # no unigram in common


def test_self_bleu_equals_the_mean_of_nltk_figures():
    texts = ["The ego vehicle stops because a pedestrian crosses the road.",
             "The ego vehicle stops because a cyclist crosses the road ahead.",
             "An ambulance approaches from behind and the ego vehicle yields.",
             "The traffic light turns red, and the ego vehicle stops."]
    toks = [tokenize(t) for t in texts]
    figures = [_nltk([t for j, t in enumerate(toks) if j != i], h) for i, h in enumerate(toks)]
    assert self_bleu(texts) == sum(figures) / len(figures)
