"""The actors of an imported OpenSCENARIO file in a scenario (:mod:`regen.driving.interop.importing`
reads them into :class:`~regen.driving.world.setting.ImportedStoryboard`).

They ride on the behavior, as a recorded ego does, so every scenario grounded for that behavior
keeps them: an import, and the what-ifs and augmentations made from it, where the rules place
the added causes around them. Their entities join the scenario's, their cause states join its
FSM before the ego's reaction.
"""

from __future__ import annotations

from regen.core.scenario import FSM, Entity, Stage, StateRef
from regen.driving.world.setting import ImportedStoryboard
from regen.verify.fidelity import IMPORTED


def imported_entities(board: ImportedStoryboard) -> list[Entity]:
    """The scenario entities of the imported actors."""
    return [Entity(name=a.name, asset=a.asset, kind="object" if a.kind == "object" else "agent",
                   properties=dict(a.properties), behavior=IMPORTED,
                   behavior_params={"event": a.event, "condition": a.condition}) for a in board.actors]


def with_imported(fsm: FSM, board: ImportedStoryboard, reactions: set[str]) -> FSM:
    """``fsm`` with the imported cause states as stages before the first stage of the ego's
    reaction (``reactions``: the names of the ego's reaction states), in the file's order."""
    causes = [a.cause for a in board.actors if a.cause is not None]
    if not causes:
        return fsm
    have = {(s.actor, s.name) for s in fsm.states}
    states = list(fsm.states) + [c for c in causes if (c.actor, c.name) not in have]
    stages = list(fsm.stages)
    at = next((i for i, st in enumerate(stages)
               if any(c.actor == "ego" and c.state in reactions for c in st.conditions)), len(stages))
    new = [Stage(conditions=[StateRef(actor=c.actor, state=c.name)]) for c in causes]
    return FSM(states=states, stages=stages[:at] + new + stages[at:])


__all__ = ["imported_entities", "with_imported"]
