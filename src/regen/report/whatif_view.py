"""The report's "What if" section: the counterfactuals ``regen whatif`` wrote under ``RUN/whatif/``,
read as plain JSON (``whatif.json``; a broken one is listed with its problem, never fatal)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from regen.report.links import href
from regen.runfolder import RunFolder

WHATIF = RunFolder.WHATIF

__all__ = ["WhatIfRow", "load_whatifs"]


@dataclass
class WhatIfRow:
    folder: str  # RUN/whatif/<folder>
    original: str = ""  # the original scenario folder's name
    original_href: str | None = None  # its section's anchor in the page
    edits: list[str] = field(default_factory=list)  # in words
    question: str | None = None
    original_status: str = ""
    status: str = ""
    explained: bool = False
    reason: str = ""
    before_gif: str | None = None
    after_gif: str | None = None
    page: str | None = None  # whatif.html
    stages_changed: list[dict[str, Any]] = field(default_factory=list)
    shown_states: list[dict[str, Any]] = field(default_factory=list)
    judge: str = ""  # who judged whether the edited cause still causes the behavior, and what
    problem: str | None = None


def _words(edit: Any) -> str:
    if not isinstance(edit, dict):
        return "?"
    op = edit.get("op")
    if op == "set":
        return f"set {edit.get('entity')}.{edit.get('property')} = {edit.get('value')}"
    if op == "remove":
        return f"remove {edit.get('entity')}"
    return f"add cause '{edit.get('text')}'"


def _gif(run: Path, folder: Path) -> str | None:
    """href of a scenario folder's animation (its files.json role) from report.html."""
    from regen.contract import ANIMATION
    from regen.runfolder import ScenarioFolder

    name = ScenarioFolder(folder).files().get(ANIMATION)
    try:
        return href(*(folder / name).resolve().relative_to(Path(run).resolve()).parts) if name else None
    except ValueError:  # outside the run folder
        return None


def load_whatifs(run_dir: Path, anchors: dict[str, str]) -> list[WhatIfRow]:
    """Every ``RUN/whatif/*/whatif.json``; ``anchors``: scenario folder name -> its section id."""
    base = Path(run_dir) / WHATIF
    if not base.is_dir():
        return []
    rows = []
    for folder in sorted(p for p in base.iterdir() if p.is_dir()):
        row = WhatIfRow(folder=folder.name)
        try:
            raw = json.loads((folder / "whatif.json").read_text(encoding="utf-8"))
            if not isinstance(raw, dict):
                raise ValueError("not a JSON object")
        except (OSError, ValueError) as exc:
            row.problem = f"whatif.json unreadable: {exc}"
            rows.append(row)
            continue
        original = Path(str(raw.get("original", "")))
        row.original = original.name
        row.original_href = anchors.get(original.name)
        row.edits = [_words(e) for e in raw.get("edits", []) if isinstance(raw.get("edits"), list)]
        row.question = raw.get("question") if isinstance(raw.get("question"), str) else None
        row.original_status = str(raw.get("original_status", ""))
        row.status = str(raw.get("status", ""))
        row.explained = raw.get("explained") is True
        row.reason = str(raw.get("reason", ""))
        judged = raw.get("judged") if isinstance(raw.get("judged"), dict) else {}
        if judged.get("by") not in (None, "none"):
            verdict = "a plausible cause" if judged.get("plausible") else "no cause"
            row.judge = f"judged by {judged.get('by')}: {verdict} of what follows it ({judged.get('reason', '')})"
        else:
            row.judge = "not judged by a model: the simulation alone decided"
        row.stages_changed = [c for c in raw.get("stages_changed", []) if isinstance(c, dict)]
        row.shown_states = [c for c in raw.get("shown_states", []) if isinstance(c, dict)]
        row.before_gif = _gif(run_dir, original) if original.is_dir() else None
        row.after_gif = _gif(run_dir, folder)
        if (folder / "whatif.html").is_file():
            row.page = href(WHATIF, folder.name, "whatif.html")
        rows.append(row)
    return rows
