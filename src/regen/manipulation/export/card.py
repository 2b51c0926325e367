"""The dataset card (``README.md``) of a LeRobot dataset regen wrote: what it holds, where each
episode came from, what was left out and why, and whether LeRobot's own loader read it back.

A folder of parquet files says little to the person who opens it; the Hub shows a dataset's
README.md as its card. Task texts come from the runs (a model may have written them): they are
written as table cells with ``|`` and line breaks neutralised, never as markup of their own.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from regen.core.io import atomic_write_text

CARD = "README.md"
CHECK_HEADING = "## Read back by LeRobot"


def _cell(text: Any) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def card_text(written: dict[str, Any], repo_id: str) -> str:
    """The card of a dataset described by ``written`` (what ``_write_dataset`` returned, with
    ``episode_list``, ``skipped``, ``fps``, ``cameras``, ``image_size``)."""
    eps = written.get("episode_list") or []
    size = "x".join(str(v) for v in written.get("image_size") or [])
    lines = [
        "# regen manipulation episodes (LeRobot v3.0)",
        "",
        f"Written by regen from verified manipulation scenarios: {written.get('episodes', len(eps))} episodes, "
        f"{written.get('frames', 0)} frames at {written.get('fps')} fps.",
        "",
        f"- Cameras: {', '.join(f'`{c}`' for c in written.get('cameras') or [])}"
        + (f" ({size} px)" if size else ""),
        f"- `action`: {written.get('action', '')}",
        f"- `next.reward`: {'the scenario reward at each frame' if written.get('reward') else 'not present'}",
        "",
        "| episode | scenario | task | frames | verdict |",
        "|---|---|---|---|---|",
        *(f"| {e['index']} | {_cell(e['scenario'])} | {_cell(e['task'])} | {e['frames']} | {_cell(e['status'])} |"
          for e in eps),
    ]
    by_name = {e["scenario"]: e["index"] for e in eps}
    if written.get("same_motion"):
        lines += ["", "## Same motion", ""]
        for names in written["same_motion"]:
            idx = ", ".join(str(by_name.get(n, "?")) for n in names)
            lines.append(f"- Episodes {idx} ({', '.join(_cell(n) for n in names)}) hold the same states, actions "
                         "and pictures: their contexts differ only in words the simulation does not show. As "
                         "training data they are duplicates.")
    lines += ["", "## Left out", ""]
    lines += [f"- {_cell(s)}" for s in written.get("skipped") or []] or ["- nothing: every scenario verified"]
    lines += ["", "## Load it", "", "```python",
              "from lerobot.datasets.lerobot_dataset import LeRobotDataset",
              "",
              f'ds = LeRobotDataset("{repo_id}", root="path/to/this/folder")',
              "```", ""]
    return "\n".join(lines)


def write_card(out: Path, written: dict[str, Any], repo_id: str) -> Path:
    path = Path(out) / CARD
    atomic_write_text(path, card_text(written, repo_id))
    return path


def add_check(out: Path, note: str) -> None:
    """Append (or replace) the section that says whether LeRobot's loader read the dataset."""
    path = Path(out) / CARD
    if not path.is_file():
        return
    text = path.read_text(encoding="utf-8")
    text = text.split(f"\n{CHECK_HEADING}\n", 1)[0].rstrip("\n") + "\n"
    atomic_write_text(path, f"{text}\n{CHECK_HEADING}\n\n{_cell(note)}\n")


__all__ = ["CARD", "add_check", "card_text", "write_card"]
