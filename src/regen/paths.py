"""Where the toolkit keeps caches (maps, model files, trained policies, LLM answers).

Never in the package folder and never relative to the working directory: the user cache dir,
``$REGEN_CACHE_DIR``, else ``$XDG_CACHE_HOME/regen``, else ``~/.cache/regen``.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir(*parts: str) -> Path:
    """The cache folder (created), optionally a subfolder of it."""
    root = os.environ.get("REGEN_CACHE_DIR")
    if root:
        base = Path(root).expanduser()
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "regen"
    path = base.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path
