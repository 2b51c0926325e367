"""Prompt templates live beside this module as Jinja2 files (``prompts/*.j2``)."""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import jinja2


@lru_cache(maxsize=1)
def _env() -> jinja2.Environment:
    # Prompts are plain text: no HTML autoescaping, but undefined variables are errors.
    return jinja2.Environment(undefined=jinja2.StrictUndefined, autoescape=False,
                              keep_trailing_newline=False, trim_blocks=False)


def render(package: str, name: str, **variables: object) -> str:
    """Render ``prompts/<name>.j2`` of ``package`` with ``variables``."""
    text = resources.files(package).joinpath("prompts", f"{name}.j2").read_text("utf-8")
    return _env().from_string(text).render(**variables).strip()
