"""The manipulation domain's asset database (``data/assets.json``)."""

from __future__ import annotations

from regen.assets.database import AssetDatabase, load_packaged_database

RESOURCE = ("regen.manipulation", "data/assets.json")


def database() -> AssetDatabase:
    """The manipulation asset database, parsed once."""
    return load_packaged_database(*RESOURCE)
