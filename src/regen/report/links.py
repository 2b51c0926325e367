"""Links from report.html to files of its run folder."""

from __future__ import annotations

from urllib.parse import quote


def href(*parts: str) -> str:
    """A relative URL to a file in the run folder (each part percent-encoded)."""
    return "/".join(quote(p) for p in parts)


__all__ = ["href"]
