"""The manipulation world: the twelve tasks the robot already knows (reward, success, script),
the project-generated furniture URDFs and the typed settings of a behavior and a scenario.

Imports: the shared core and errors only (no other manipulation stage).
"""

from regen.manipulation.world.furniture import AABB, FURNITURE, FurnitureSpec, furniture
from regen.manipulation.world.setting import ManipulationParams, ManipulationWorld
from regen.manipulation.world.tasks import (
    BEHAVIORS,
    BehaviorDef,
    get_behavior,
    match_behavior,
    resolve,
)

__all__ = ["AABB", "BEHAVIORS", "FURNITURE", "BehaviorDef", "FurnitureSpec", "ManipulationParams",
           "ManipulationWorld", "furniture", "get_behavior", "match_behavior", "resolve"]
