"""Asset databases: what each simulator can simulate, as a directed graph (paper appendix)."""

from regen.assets.database import AssetDatabase, load_database, load_packaged_database

__all__ = ["AssetDatabase", "load_database", "load_packaged_database"]
