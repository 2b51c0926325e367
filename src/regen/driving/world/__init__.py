"""The driving world: generated maps, start locations, actor kinds and sizes, time-changing
properties, triggers, the ego template and the plan of who does what, with the CP-SAT placement
variables every primitive constrains.

Imports: the shared core and errors only (no other driving stage).
"""
