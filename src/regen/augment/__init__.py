"""Augmentation of an existing scene (paper, contribution i): the model reasons backwards from the
robot's behavior with the scene's entities as context, and proposes (a) causes to add, each
naming an entity that would cause or strengthen the behavior, and (b) entities already present
that are irrelevant to it. Each proposal is tested, not believed: an addition becomes a
counterfactual (:func:`regen.whatif.run_whatif` with an ``add`` edit) grounded, simulated and
verified as usual; a claimed-irrelevant entity is removed and the scene simulated again, and the
claim holds only if the behavior is still explained. ``augment.json`` and ``augment.html``
list both with their verdicts; the counterfactual folders sit with the run's what-ifs, so the
run's report shows them too.
"""
from regen.augment.run import (
    AUGMENT_HTML,
    AUGMENT_JSON,
    MAX_ADD,
    Augmentation,
    Proposal,
    Tried,
    cast_lines,
    page,
    propose,
    run_augment,
)

__all__ = ["AUGMENT_HTML", "AUGMENT_JSON", "MAX_ADD", "Augmentation", "Proposal", "Tried", "cast_lines", "page",
           "propose", "run_augment"]
