"""Text diversity metrics of the paper (section 3.3): embedding diversity and Self-BLEU diversity.

- Embedding diversity = 1 - mean pairwise cosine similarity of Sentence-BERT
  (all-MiniLM-L6-v2) embeddings, over all unordered pairs of distinct items.
- Self-BLEU diversity = 1 - Self-BLEU, where Self-BLEU is the mean over items of the sentence
  BLEU-4 of that item against all the other items as references (Texygen's definition), with
  BLEU-4 exactly as nltk's ``sentence_bleu`` computes it with uniform weights (1/4 each) and
  ``SmoothingFunction().method1`` (epsilon 0.1 added to zero n-gram counts, as Texygen does), in
  :mod:`regen.evaluation.bleu` without nltk. Tokens are lowercased words and
  single punctuation marks (``tokenize``), which needs no tokenizer download.

The paper's protocol (``compare_sets``): n = the smallest set size among the compared sets;
from every set, draw n items without replacement, compute both metrics, repeat 10 times, and
report mean and standard deviation. Draws are seeded per set name, so a set's figures do not
change when other sets join the comparison (unless n changes).
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Callable, Sequence

import numpy as np
from pydantic import BaseModel, Field

from regen.errors import ConfigError
from regen.evaluation.bleu import bleu4_of_counts, ngram_counts

_TOKEN = re.compile(r"\w+|[^\w\s]")


def tokenize(text: str) -> list[str]:
    """Lowercased word and punctuation tokens: 'Ego stops.' -> ['ego', 'stops', '.']."""
    return _TOKEN.findall(text.lower())


def pairwise_cosine(embeddings: np.ndarray) -> np.ndarray:
    """Cosine similarity matrix ``(n, n)`` of row vectors (rows need not be normalized)."""
    e = np.asarray(embeddings, dtype=np.float64)
    norms = np.linalg.norm(e, axis=1, keepdims=True)
    e = e / np.clip(norms, 1e-12, None)
    return e @ e.T


def embedding_diversity_of_vectors(embeddings: np.ndarray) -> float:
    """1 - mean cosine similarity over all unordered pairs of distinct rows, in [0, 2].

    Needs at least two rows.
    """
    n = len(embeddings)
    if n < 2:
        raise ConfigError("embedding diversity needs at least two texts")
    sim = pairwise_cosine(embeddings)
    iu = np.triu_indices(n, k=1)
    return float(1.0 - sim[iu].mean())


def embedding_diversity(texts: Sequence[str], encoder=None) -> float:
    """Embedding diversity of ``texts`` with all-MiniLM-L6-v2 (see module doc)."""
    if encoder is None:
        from regen.embeddings import default_encoder

        encoder = default_encoder()
    return embedding_diversity_of_vectors(encoder.encode(list(texts)))


def self_bleu(texts: Sequence[str]) -> float:
    """Mean BLEU-4 of each text against all others as references (nltk's figure, smoothing
    method1; :mod:`regen.evaluation.bleu`).

    Needs at least two texts. Identical texts give 1.0; texts sharing no word give ~0.
    """
    if len(texts) < 2:
        raise ConfigError("Self-BLEU needs at least two texts")
    toks = [tokenize(t) for t in texts]
    counts = [ngram_counts(t) for t in toks]
    lens = [len(t) for t in toks]
    scores = []
    for i in range(len(toks)):
        others = [j for j in range(len(toks)) if j != i]
        scores.append(bleu4_of_counts(counts[i], lens[i], [counts[j] for j in others],
                                      [lens[j] for j in others]))
    return float(np.mean(scores))


def self_bleu_diversity(texts: Sequence[str]) -> float:
    """1 - Self-BLEU of ``texts``."""
    return 1.0 - self_bleu(texts)


# --- the sampling protocol -------------------------------------------------------------------


class MetricSummary(BaseModel):
    mean: float
    std: float  # population std over the repeats
    values: list[float] = Field(default_factory=list)  # one per repeat


class SetDiversity(BaseModel):
    """Diversity of one text set under the protocol."""

    name: str
    size: int  # items in the set
    sample_size: int  # n drawn per repeat
    repeats: int
    embedding_diversity: MetricSummary | None = None
    self_bleu_diversity: MetricSummary | None = None


def _set_seed(seed: int, name: str) -> np.random.Generator:
    # crc32 of the name, not hash(): Python salts str hashes per process
    return np.random.default_rng([seed, zlib.crc32(name.encode("utf-8"))])


def sample_indices(size: int, n: int, repeats: int, seed: int, name: str) -> list[np.ndarray]:
    """The ``repeats`` index draws (n of ``size``, without replacement) for set ``name``.

    When n equals the set size every draw is the whole set (in order), so its std is 0.
    """
    if n > size:
        raise ConfigError(f"cannot draw {n} items from the set {name!r} of {size}")
    rng = _set_seed(seed, name)
    if n == size:
        return [np.arange(size) for _ in range(repeats)]
    return [np.sort(rng.choice(size, size=n, replace=False)) for _ in range(repeats)]


def _summary(values: list[float]) -> MetricSummary:
    arr = np.asarray(values, dtype=np.float64)
    return MetricSummary(mean=float(arr.mean()), std=float(arr.std()), values=[float(v) for v in arr])


def compare_sets(
    sets: dict[str, Sequence[str]],
    *,
    n: int | None = None,
    repeats: int = 10,
    seed: int = 0,
    embeddings: bool = True,
    self_bleu_metric: bool = True,
    encoder=None,
    progress: Callable[[str], None] | None = None,
) -> list[SetDiversity]:
    """Diversity of each named text set under the paper's protocol.

    ``n`` defaults to the smallest set size (and is capped by it); ``repeats`` draws per set;
    ``seed`` makes the draws reproducible. Each set is embedded once and the draws index into it.
    """
    if not sets:
        raise ConfigError("no text sets to compare")
    if repeats < 1:
        raise ConfigError("repeats must be at least 1")
    smallest = min(len(v) for v in sets.values())
    n = smallest if n is None else min(n, smallest)
    if n < 2:
        small = [k for k, v in sets.items() if len(v) < 2]
        raise ConfigError(f"each set needs at least two texts to measure diversity; too small: {small}")
    if embeddings and encoder is None:
        from regen.embeddings import default_encoder

        encoder = default_encoder()
    results = []
    for name, texts in sets.items():
        texts = list(texts)
        if progress:
            progress(name)
        draws = sample_indices(len(texts), n, repeats, seed, name)
        res = SetDiversity(name=name, size=len(texts), sample_size=n, repeats=repeats)
        if embeddings:
            vecs = encoder.encode(texts)
            res.embedding_diversity = _summary(
                [embedding_diversity_of_vectors(vecs[d]) for d in draws])
        if self_bleu_metric:
            cache: dict[bytes, float] = {}  # identical draws (n == size) are scored once
            vals = []
            for d in draws:
                key = d.tobytes()
                if key not in cache:
                    cache[key] = self_bleu_diversity([texts[i] for i in d])
                vals.append(cache[key])
            res.self_bleu_diversity = _summary(vals)
        results.append(res)
    return results
