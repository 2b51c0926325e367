"""Driving predicates (relative position, motion, lights, collisions) for the shared FSM
monitor, collision and infraction detection over a trace (the safety oracle's facts), and the
NHTSA pre-crash typology's rules (``typology``: which of the 37 classes a trace shows).

Imports: ``world`` of this domain and the shared core and verify packages.
"""
