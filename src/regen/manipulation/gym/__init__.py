"""The Gymnasium env ``regen/Manipulation-v0`` over a run's verified manipulation scenarios.

Imports: ``testing`` and lower stages of this domain.
"""
