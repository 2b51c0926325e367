"""The one Jinja2 loader: prompts, the Scenic program and the report's HTML.

Templates are package data, found by (package, folder): prompts are ``prompts/<name>.j2``
beside the module that uses them. Undefined variables are errors everywhere (a typo fails the
tests, not silently). The caller chooses escaping: prompts and programs are plain text
(``html=False``), the report is HTML (``html=True``: every inserted string is escaped).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import jinja2


@lru_cache(maxsize=16)
def environment(package: str, folder: str = "prompts", *, html: bool = False,
                keep_trailing_newline: bool = False, finalize: Callable[[object], object] | None = None
                ) -> jinja2.Environment:
    """The environment of the templates in ``folder`` of ``package`` (made once per arguments).

    ``html``: escape every inserted value, and drop the newline after a block tag and the
    indentation before it (the report's markup); ``finalize``: applied to every ``{{ }}`` value."""
    return jinja2.Environment(loader=jinja2.PackageLoader(package, folder), autoescape=html,
                              undefined=jinja2.StrictUndefined, keep_trailing_newline=keep_trailing_newline,
                              trim_blocks=html, lstrip_blocks=html, finalize=finalize)


def render(package: str, name: str, **variables: object) -> str:
    """Render the prompt ``prompts/<name>.j2`` of ``package`` with ``variables``, stripped."""
    return environment(package).get_template(f"{name}.j2").render(**variables).strip()


__all__ = ["environment", "render"]
