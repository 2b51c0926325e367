"""Calibrated yes/no decisions of the cause judge.

Asked at once, a small model says yes to nearly every candidate cause (recall 1.00, precision
0.65 on held-out driving edges): its written answer is a poor decision. Its probability of
"yes" against "no" as the answer's first word (:meth:`regen.llm.LLM.weigh`) can be cut at a
threshold instead; that threshold belongs to one model and one prompt, and
is chosen on the *tune* half of a labeled edge set only (``scripts/calibrate_judge.py`` prints
it; the *test* half is what ``regen eval --edges`` reports, and only a threshold that improves
the test half belongs here). A model without a threshold here, or whose provider gives no
probabilities (remote APIs), is decided by its written answer.

Imports: nothing of the toolkit.
"""

from __future__ import annotations

#: provider id -> least P(yes) at which the event judge accepts a candidate cause. Empty: no
#: model is calibrated by default. Measured 2026-11-24 for local:qwen2.5-coder-1.5b: the tune
#: half (31 event->event rows) chose 0.636 (tune accuracy driving 0.81 -> 0.94, manipulation
#: 0.87 -> 1.00), but on the test half accuracy fell (driving 0.78 -> 0.67, manipulation
#: 0.89 -> 0.78): on sets this small the cut does not carry over, so the written answer decides.
JUDGE_THRESHOLDS: dict[str, float] = {}

#: What the judge's answer starts with: the field the yes/no is read from.
ANSWER_PREFIX = '{"answer": "'


def threshold_for(provider_id: str) -> float | None:
    """The calibrated threshold of a model, or None (decide by its written answer)."""
    return JUDGE_THRESHOLDS.get(provider_id)
