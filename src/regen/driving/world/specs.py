"""One typed spec per module of a package: how the primitives and the ego templates are collected.

Imports: the standard library only.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable


def one_per_module(package: str, path: Iterable[str], attr: str, key: str, what: str) -> list[object]:
    """The ``attr`` of every public module of ``package`` (its ``__path__`` is ``path``) but its
    ``base`` and ``registry`` modules and its subpackages, in module-name order; each spec's ``key`` attribute must be its module's name (``what`` names
    the spec in the error)."""
    specs = []
    for info in sorted(pkgutil.iter_modules(path), key=lambda i: i.name):
        if info.name.startswith("_") or info.ispkg or info.name in ("base", "registry"):
            continue
        spec = getattr(importlib.import_module(f"{package}.{info.name}"), attr)
        if getattr(spec, key) != info.name:
            raise ValueError(f"{package}.{info.name} defines the {what} {getattr(spec, key)!r}; "
                             f"name the module after its {what}")
        specs.append(spec)
    return specs
