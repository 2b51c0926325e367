"""The diversity of what a batch made: the paper's embedding and Self-BLEU diversity (section
3.3, :mod:`regen.evaluation.diversity`) over the texts of every feasible scenario of the batch,
overall and per domain. The embedding metric needs the ``eval`` extra (Self-BLEU needs nothing
more); when it cannot be computed it is skipped with the reason (``Diversity.skipped``), never an
error, so a batch's summary never fails for want of an optional package."""

from __future__ import annotations

from typing import Protocol

import numpy as np
from pydantic import Field

from regen.core.base import Model
from regen.errors import RegenError
from regen.evaluation.diversity import embedding_diversity, sample_indices, self_bleu_diversity

__all__ = ["METRICS", "Diversity", "DiversityFigure", "Encoder", "batch_diversity"]

METRICS = {"embedding": "embedding diversity (all-MiniLM-L6-v2)", "self_bleu": "Self-BLEU diversity"}
MAX_DIVERSITY_TEXTS = 200  # Self-BLEU is quadratic in the texts: a larger set is sampled (seeded)


class Encoder(Protocol):
    """What the embedding metric needs of a sentence encoder (:mod:`regen.embeddings`)."""

    def encode(self, texts: list[str]) -> np.ndarray: ...


class DiversityFigure(Model):
    """Both metrics over one set of texts (None: not computed, ``Diversity.skipped`` says why)."""

    scope: str  # 'all' or a domain
    texts: int  # feasible scenarios' texts measured
    embedding: float | None = None
    self_bleu: float | None = None


class Diversity(Model):
    """Diversity of the feasible scenarios' texts (narrative, else the cause chain)."""

    computed: list[str] = Field(default_factory=list)  # metric ids (METRICS) that were computed
    skipped: dict[str, str] = Field(default_factory=dict)  # metric id or scope -> why not
    figures: list[DiversityFigure] = Field(default_factory=list)


def _encoder(embeddings: bool, encoder: Encoder | None, out: Diversity) -> Encoder | None:
    """The sentence encoder, or None with the reason in ``out.skipped``."""
    if not embeddings:
        out.skipped["embedding"] = "turned off"
        return None
    if encoder is not None:
        return encoder
    try:
        from regen.embeddings import default_encoder

        return default_encoder()
    except RegenError as exc:  # the eval extra is missing, or its model file is damaged
        out.skipped["embedding"] = str(exc)
        return None


def _sample(texts: list[str], scope: str) -> list[str]:
    if len(texts) <= MAX_DIVERSITY_TEXTS:
        return texts
    (picked,) = sample_indices(len(texts), MAX_DIVERSITY_TEXTS, 1, 0, scope)
    return [texts[i] for i in picked]


def batch_diversity(texts_by_domain: dict[str, list[str]], *, embeddings: bool = True,
                    encoder: Encoder | None = None) -> Diversity:
    """Embedding and Self-BLEU diversity (paper 3.3) of the texts, over all domains and, when
    there are several, per domain. A metric whose package (the ``eval`` extra) is missing is
    skipped with the reason; a scope with fewer than two texts is skipped too."""
    out = Diversity()
    scopes = {"all": [t for texts in texts_by_domain.values() for t in texts]}
    if len(texts_by_domain) > 1:
        scopes.update(sorted(texts_by_domain.items()))
    usable = {}
    for scope, texts in scopes.items():
        if len(texts) < 2:
            out.skipped[scope] = f"{len(texts)} feasible scenario text(s); diversity needs at least two"
        else:
            usable[scope] = _sample(texts, scope)
    if not usable:
        return out
    enc = _encoder(embeddings, encoder, out)
    for scope, texts in usable.items():
        fig = DiversityFigure(scope=scope, texts=len(scopes[scope]))
        if enc is not None:
            fig.embedding = embedding_diversity(texts, enc)
        fig.self_bleu = self_bleu_diversity(texts)
        out.figures.append(fig)
    out.computed = [m for m in METRICS if m not in out.skipped]
    return out
