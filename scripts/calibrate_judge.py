"""Choose the event judge's threshold on the tune half of the bundled labeled edges.

Usage: python scripts/calibrate_judge.py [--llm local] [--edges FILE]

Weighs every tune-half event->event row (of the bundled sets, or of FILE) with the model (its probability of "yes" as the
answer's first word, the same question expansion asks), prints each score and the threshold
that separates the labels best (the midpoint of the widest gap among the most accurate cuts).
Copy it into ``regen/expand/calibration.py``. The test half is never read here.
"""

from __future__ import annotations

import argparse

from regen.evaluation.edges import bundled_edge_examples, context_chain, load_edge_examples
from regen.expand.calibration import ANSWER_PREFIX
from regen.expand.edges import domain_view, event_question
from regen.llm import LLM


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", default="local")
    ap.add_argument("--edges", help="a labeled edge file with a split (default: the bundled sets)")
    args = ap.parse_args()
    llm = LLM(args.llm)
    rows = [r for r in load_edge_examples(args.edges or bundled_edge_examples())
            if r.kind == "event->event" and r.split == "tune"]
    scored = []
    for r in rows:
        d = domain_view(r.domain)
        q = event_question(d, [r.source, *context_chain(r.context, r.source)], r.candidate)
        p = llm.weigh(q, ("yes", "no"), prefix=ANSWER_PREFIX, purpose="calibrate", system=d.system).value["yes"]
        scored.append((p, r.label, r.domain))
        print(f"{r.domain:13} {'yes' if r.label else 'no ':3}  P(yes) = {p:.3f}  {r.candidate}")
    cuts = sorted({p for p, _, _ in scored})
    best = max(((sum((p >= (a + b) / 2) == lab for p, lab, _ in scored) / len(scored), b - a, (a + b) / 2)
                for a, b in zip(cuts, cuts[1:], strict=False)), default=None)
    if best is None:
        raise SystemExit("fewer than two distinct scores: nothing to calibrate")
    acc, _, t = best
    print(f"\nthreshold {t:.3f} for {llm.provider.id}: tune accuracy {acc:.2f} over {len(scored)} rows")
    for dom in sorted({d for _, _, d in scored}):
        mine = [(p, lab) for p, lab, d in scored if d == dom]
        print(f"  {dom}: {sum((p >= t) == lab for p, lab in mine) / len(mine):.2f} over {len(mine)} rows")


if __name__ == "__main__":
    main()
