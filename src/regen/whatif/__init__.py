"""Counterfactual what-if: a scenario's cause chain edited, then grounded, simulated and verified again.

The paper's second contribution: perturb the causal graph with a what-if question and see
whether the robot's behavior is still explained. An edit is one of

- ``set``: ``ENTITY.PROPERTY=VALUE`` (``sedan1.brake_lights=broken``; ``truck1.start_location=...``),
  checked against the asset database's values for that asset;
- ``remove``: an entity of the cause chain leaves the scene;
- ``add``: a cause text joins the chain as a new root event, its entities those its words name
  in the database (``a cyclist rides ahead``).

:func:`apply_edits` turns the original scenario's cause path into the counterfactual's: every
entity keeps the values the original scenario had (its behavior, states and start place pinned),
so only what the edits touch changes. :func:`run_whatif` grounds, simulates and verifies the
edited path with the main job's own stage function (:func:`regen.pipeline.stages.run_path`)
into ``OUT/<original>-whatif-<hash>/`` (its own ``scenario.json`` and ``verdict.json``), and writes
``whatif.json`` there: the original's folder (linked, not copied), the edits, both verdicts,
the FSM stages that changed and whether the robot's behavior is still explained (a verified
counterfactual). Removing the cause may leave it unexplained: that is a result, not an error.
``whatif.html`` shows the pair side by side.

A question in words (``--ask``) goes to the model, which answers with edits
(:func:`ask_edits`): data validated by pydantic and by :func:`apply_edits`, never executed.
"""

from regen.whatif.edits import (
    Edit,
    Edits,
    actual_values,
    apply_edits,
    ask_edits,
    cast_lines,
    cast_of,
    context_of,
    parse_set,
    path_pairs,
)
from regen.whatif.page import WHATIF_HTML, page
from regen.whatif.record import WHATIF_JSON, WhatIf, changed_stages, stage_lines
from regen.whatif.run import folder_name, judge_root, prepare, run_whatif

__all__ = ["WHATIF_HTML", "WHATIF_JSON", "Edit", "Edits", "WhatIf", "actual_values", "apply_edits", "ask_edits", "cast_lines", "cast_of", "context_of",
           "changed_stages", "folder_name", "judge_root", "page", "parse_set", "path_pairs", "prepare", "run_whatif",
           "stage_lines"]
