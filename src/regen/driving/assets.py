"""The driving domain's asset database (``data/assets.json``)."""

from __future__ import annotations

from regen.assets.database import AssetDatabase, load_packaged_database

RESOURCE = ("regen.driving", "data/assets.json")


def database() -> AssetDatabase:
    """The driving asset database, parsed once."""
    return load_packaged_database(*RESOURCE)
