"""Evaluation of generated scenarios (paper section 3.3 and appendix ablations).

Diversity (Sentence-BERT embeddings, Self-BLEU) under the paper's sampling protocol,
feasibility breakdown per behavior and scenario, edge-construction accuracy, controllability.
The embedding model (onnxruntime, tokenizers) comes with the ``eval`` extra and is imported only
when used; Self-BLEU needs nothing more (:mod:`regen.evaluation.bleu`).
"""

from regen.evaluation.controllability import ControllabilityReport, controllability
from regen.evaluation.diversity import (
    SetDiversity,
    compare_sets,
    embedding_diversity,
    embedding_diversity_of_vectors,
    self_bleu,
    self_bleu_diversity,
)
from regen.evaluation.edges import (
    EdgeExample,
    EdgeReport,
    evaluate_edges,
    load_edge_examples,
    model_judge,
)
from regen.evaluation.evaluate import EvalReport, EvalSettings, evaluate
from regen.evaluation.feasibility import FeasibilityReport, feasibility_breakdown
from regen.evaluation.runs import RunRecord, load_run
from regen.evaluation.textsets import TextSet, load_text_set, load_text_sets

__all__ = [
    "ControllabilityReport",
    "EdgeExample",
    "EdgeReport",
    "EvalReport",
    "EvalSettings",
    "FeasibilityReport",
    "RunRecord",
    "SetDiversity",
    "TextSet",
    "compare_sets",
    "controllability",
    "embedding_diversity",
    "embedding_diversity_of_vectors",
    "evaluate",
    "evaluate_edges",
    "feasibility_breakdown",
    "load_edge_examples",
    "load_run",
    "load_text_set",
    "load_text_sets",
    "model_judge",
    "self_bleu",
    "self_bleu_diversity",
]
