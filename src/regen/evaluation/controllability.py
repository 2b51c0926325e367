"""Controllability (paper appendix, "Eliciting Diversity & Controllability").

For every pair of scenarios of the same behavior: how different their causes are, and how
different their texts are. The cause difference of a pair is the share of its cause events
(behavior node excluded) that only one of the two scenarios has, 1 - |A & B| / |A | B|: 100 %
means entirely distinct causes, 0 % the same cause with different properties (locations,
behaviors, states). The text difference is the embedding diversity of the pair, 1 - cosine.
The paper finds a bimodal distribution: new causes give larger text differences than new
properties. ``controllability`` returns the pair table, the share of pairs in each group and the
per-group statistics; ``plots.controllability_histogram`` draws the histogram.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
from pydantic import BaseModel, Field

from regen.evaluation.diversity import pairwise_cosine
from regen.evaluation.runs import ScenarioRecord

DIFFERENT_CAUSE = "different cause"
SAME_CAUSE = "same cause, different properties"


class ScenarioPair(BaseModel):
    behavior: str
    a: str  # scenario id
    b: str
    cause_difference: float  # share of cause events not shared, in [0, 1]
    group: str  # DIFFERENT_CAUSE or SAME_CAUSE
    diversity: float | None = None  # 1 - cosine of the two texts' embeddings


class GroupStats(BaseModel):
    pairs: int
    share: float  # of all pairs
    diversity_mean: float | None = None
    diversity_std: float | None = None


class ControllabilityReport(BaseModel):
    pairs: list[ScenarioPair] = Field(default_factory=list)
    groups: dict[str, GroupStats] = Field(default_factory=dict)
    # Pearson correlation of cause difference and text diversity over pairs (None if undefined)
    correlation: float | None = None


def cause_difference(a: list[str], b: list[str]) -> float:
    """1 - Jaccard similarity of two cause sets (labels compared case- and space-insensitively)."""
    sa = {" ".join(x.lower().split()) for x in a}
    sb = {" ".join(x.lower().split()) for x in b}
    union = sa | sb
    if not union:
        return 0.0
    return 1.0 - len(sa & sb) / len(union)


def controllability(scenarios: list[ScenarioRecord], encoder=None, *,
                    embeddings: bool = True) -> ControllabilityReport:
    """Pairwise cause and text differences of scenarios, paired within each behavior.

    Scenarios without any text are skipped. With ``embeddings=False`` only the group shares
    are computed.
    """
    usable = [s for s in scenarios if s.text]
    by_behavior: dict[str, list[ScenarioRecord]] = {}
    for s in usable:
        by_behavior.setdefault(s.behavior, []).append(s)
    if embeddings and encoder is None and any(len(v) > 1 for v in by_behavior.values()):
        from regen.embeddings import default_encoder

        encoder = default_encoder()
    pairs: list[ScenarioPair] = []
    for behavior, group in by_behavior.items():
        if len(group) < 2:
            continue
        sim = pairwise_cosine(encoder.encode([s.text for s in group])) if embeddings else None
        for i, j in combinations(range(len(group)), 2):
            a, b = group[i], group[j]
            diff = cause_difference(a.causes, b.causes)
            pairs.append(ScenarioPair(
                behavior=behavior, a=a.id, b=b.id, cause_difference=diff,
                group=DIFFERENT_CAUSE if diff > 0 else SAME_CAUSE,
                diversity=None if sim is None else float(1.0 - sim[i, j])))
    report = ControllabilityReport(pairs=pairs)
    for name in (DIFFERENT_CAUSE, SAME_CAUSE):
        members = [p for p in pairs if p.group == name]
        vals = np.array([p.diversity for p in members if p.diversity is not None])
        report.groups[name] = GroupStats(
            pairs=len(members), share=len(members) / len(pairs) if pairs else 0.0,
            diversity_mean=float(vals.mean()) if len(vals) else None,
            diversity_std=float(vals.std()) if len(vals) else None)
    xs = np.array([p.cause_difference for p in pairs if p.diversity is not None])
    ys = np.array([p.diversity for p in pairs if p.diversity is not None])
    if len(xs) > 2 and xs.std() > 0 and ys.std() > 0:
        report.correlation = float(np.corrcoef(xs, ys)[0, 1])
    return report
