"""Inverse design by graph expansion (paper Alg. 1)."""

from regen.expand.expansion import Limits, expand

__all__ = ["Limits", "expand"]
