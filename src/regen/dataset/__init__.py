"""``regen dataset``: vision-language-action datasets from finished driving run folders
(docs/dataset.md). ``labels`` derives the desired ego action, ``qa`` the computed
question-answer layers, ``samples`` the candidates, frames and rows, ``write`` and ``card`` the
files; ``probe`` and ``probe_score`` ask a model the questions and score it (``regen probe``). Imports: the driving domain's render and world, the run folder, what-if and harness
records."""

from regen.dataset.labels import LABELS
from regen.dataset.probe import ProbeResult, probe_dataset
from regen.dataset.write import DatasetResult, build_dataset

__all__ = ["LABELS", "DatasetResult", "ProbeResult", "build_dataset", "probe_dataset"]
