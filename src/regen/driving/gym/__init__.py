"""The Gymnasium env ``regen/Driving-v0`` over a run's verified driving scenarios.

Imports: ``testing`` and lower stages of this domain.
"""
