"""``whatif.html``: a counterfactual beside its original (pictures, verdicts, stages, edits). Its
template sits with the report's (``regen/report/templates``, :mod:`regen.report.pages`)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from regen.whatif.record import WhatIf, stage_lines

if TYPE_CHECKING:
    from regen.core.scenario import Scenario

WHATIF_HTML = "whatif.html"
WHATIF_PAGE = "whatif.html.j2"  # its template among the report's


def _picture(folder: Path, dest: Path) -> str | None:
    """The folder's animation (its files.json role), relative to ``dest``."""
    from regen.contract import ANIMATION
    from regen.runfolder import ScenarioFolder

    name = ScenarioFolder(folder).files().get(ANIMATION)
    return os.path.relpath(folder / name, dest) if name else None


def page(record: WhatIf, original: Path, dest: Path, before: Scenario, after: Scenario | None) -> str:
    """``whatif.html``: the pair side by side (pictures, verdicts, stages, edits)."""
    from regen.report.pages import page_template

    return page_template(WHATIF_PAGE).render(
        record=record, cause=before.causal_graph[0],
        after_cause=after.causal_graph[0] if after is not None else "(not grounded)",
        behavior=before.behavior.text,
        before_gif=_picture(original, dest), after_gif=_picture(dest, dest),
        before_stages=stage_lines(before), after_stages=stage_lines(after) if after else [],
        original_href=os.path.relpath(original, dest))


__all__ = ["WHATIF_HTML", "page"]
