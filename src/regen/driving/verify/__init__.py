"""Driving predicates (relative position, motion, lights, collisions) for the shared FSM
monitor, and collision and infraction detection over a trace (the safety oracle's facts).

Imports: ``world`` of this domain and the shared core and verify packages.
"""
