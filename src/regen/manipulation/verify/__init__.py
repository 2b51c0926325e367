"""Manipulation predicates (relations, joints, the hand and what it holds) for the shared FSM
monitor, over recorded PyBullet traces.

Imports: the shared core and verify packages only.
"""
