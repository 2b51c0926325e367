"""Simulation: the PyBullet scene of a scenario, the Panda's controller, the scripted motion
primitives and the optional SAC policy, the rollout and the trace it records.

Imports: ``world`` of this domain and the shared core (PyBullet only when a scene is built).
"""
