"""The pages other commands write beside their results (``whatif.html`` by ``regen whatif``,
``augment.html`` by ``regen augment``): standalone HTML whose templates sit with the report's in
``templates/``, rendered with the same escaping (every inserted string is escaped)."""

from __future__ import annotations

import jinja2

from regen.templates import environment


def page_template(name: str) -> jinja2.Template:
    """The template ``templates/<name>`` of a standalone page (``whatif.html.j2``, ``augment.html.j2``)."""
    return environment("regen.report", "templates", html=True).get_template(name)


__all__ = ["page_template"]
