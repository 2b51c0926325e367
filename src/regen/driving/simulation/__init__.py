"""Simulation: the Scenic program (and its template) of a scenario, running it, recording the
trace.

Imports: ``world`` and ``primitives`` of this domain and the shared core.
"""
