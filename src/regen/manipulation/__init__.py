"""Manipulation domain: a Franka Panda in PyBullet reusing fixed behaviors in new contexts.

Stages, bottom to top: ``world`` (the tasks, generated furniture, settings), ``grounding``
(path -> scenario: model answers and rules, CP-SAT placement, FSM), ``simulation`` (PyBullet
scene, controller, scripted primitives, optional SAC, rollout -> trace), ``verify`` (the FSM
predicate library), ``render`` (pictures), ``testing`` (policy tests) and ``gym`` (the
Gymnasium env); ``backend`` is the DomainBackend. PyBullet is imported only when a scene is
built.
"""

from regen.manipulation.world.tasks import BEHAVIORS, BehaviorDef, get_behavior, match_behavior

__all__ = ["BEHAVIORS", "BehaviorDef", "get_behavior", "match_behavior"]
