"""Sentence BLEU-4 as nltk computes it, without nltk.

``sentence_bleu4(references, hypothesis)`` returns the very float that nltk 3.x's
``sentence_bleu(references, hypothesis, weights=(0.25,) * 4,
smoothing_function=SmoothingFunction().method1)`` returns (``tests/evaluation/test_bleu.py``
compares them for equality on generated texts):

- modified n-gram precision for n = 1..4: each hypothesis n-gram's count clipped to its largest
  count in any one reference, over the hypothesis's n-gram count (at least 1);
- no unigram in common: 0;
- method1 smoothing: a precision with no match becomes ``(0 + 0.1) / count``;
- brevity penalty against the reference length closest to the hypothesis's (the shorter one on a
  tie): 1 when the hypothesis is longer, else ``exp(1 - r / c)``;
- BLEU = penalty * exp(fsum(0.25 * log(p_n))).

nltk imports scipy.stats with it (about a second, paid at the end of every batch); the n-gram
counts here are also made once per text, where Self-BLEU with nltk makes each text's counts
again for every other text.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

ORDER = 4  # BLEU-4, uniform weights
WEIGHT = 1.0 / ORDER
EPSILON = 0.1  # nltk's SmoothingFunction(epsilon=0.1).method1

NgramCounts = tuple[Counter, ...]  # one Counter of n-gram tuples per order 1..ORDER


def ngram_counts(tokens: Sequence[str]) -> NgramCounts:
    """The n-gram counts of ``tokens`` for n = 1..4 (empty where the text is shorter than n)."""
    return tuple(Counter(zip(*(tokens[i:] for i in range(n)), strict=False)) for n in range(1, ORDER + 1))


def _precisions(hyp: NgramCounts, refs: Sequence[NgramCounts]) -> list[tuple[int, int]]:
    out = []
    for n in range(ORDER):
        counts = hyp[n]
        matched = 0
        for gram, count in counts.items():
            matched += min(count, max((ref[n][gram] for ref in refs), default=0))
        out.append((matched, max(1, sum(counts.values()))))
    return out


def bleu4_of_counts(hyp: NgramCounts, hyp_len: int, refs: Sequence[NgramCounts],
                    ref_lens: Sequence[int]) -> float:
    """Sentence BLEU-4 (module doc) from precomputed :func:`ngram_counts` and lengths."""
    if not refs:
        raise ValueError("BLEU needs at least one reference")
    precisions = _precisions(hyp, refs)
    if precisions[0][0] == 0:
        return 0.0
    closest = min(ref_lens, key=lambda length: (abs(length - hyp_len), length))
    if hyp_len > closest:
        penalty = 1.0
    elif hyp_len == 0:
        penalty = 0.0
    else:
        penalty = math.exp(1 - closest / hyp_len)
    logs = (WEIGHT * math.log((EPSILON if matched == 0 else matched) / total)
            for matched, total in precisions)
    return penalty * math.exp(math.fsum(logs))


def sentence_bleu4(references: Sequence[Sequence[str]], hypothesis: Sequence[str]) -> float:
    """Sentence BLEU-4 of ``hypothesis`` against ``references`` (token lists; module doc)."""
    return bleu4_of_counts(ngram_counts(hypothesis), len(hypothesis),
                           [ngram_counts(r) for r in references], [len(r) for r in references])
