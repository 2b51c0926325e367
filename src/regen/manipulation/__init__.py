"""Manipulation domain: a Franka Panda in PyBullet reusing fixed behaviors in new contexts.

Modules: ``urdf`` (generated furniture), ``scene`` (PyBullet world), ``controller`` and
``scripted`` (IK motion primitives), ``behaviors`` (the 12 behaviors: reward, success, script),
``placement`` (CP-SAT spatial relations), ``grounding`` (path -> scenario), ``simulate``
(rollout -> trace), ``predicates`` (FSM library), ``render`` (pictures), ``rl`` (optional SAC),
``backend`` (the DomainBackend). PyBullet is imported only when a scene is built.
"""

from regen.manipulation.behaviors import BEHAVIORS, BehaviorDef, get_behavior, match_behavior

__all__ = ["BEHAVIORS", "BehaviorDef", "get_behavior", "match_behavior"]
