"""``regen falsify``: a search over a run's causes (not only its parameters) for what makes a
policy fail where the scripted robot copes.

Starting from the run's verified scenarios, candidates are what-if edits of their causes
(:mod:`.space`: ``set`` a context entity's property to another value the asset database allows,
``remove`` one, ``add`` a cause the graph's expansion proposed), breadth-first by size within a
budget (:mod:`.search`). Each candidate is a tiny run folder of its own, grounded, simulated and
verified by the main job's stage function and tested with ``regen test``'s own suite
(:mod:`.candidate`); it is the policy's failure only when the scripted robot verified in it and
collided with nothing. Failing candidates are shrunk to the fewest edits that still fail
(:mod:`.shrink`); with a model, the failures suggest new causes to add (:mod:`.proposals`).
``OUT/falsify.json`` (:mod:`.record`) lists the findings with the command that replays each.
"""

from regen.falsify.candidate import Bench, Source, kept, replay_command, run_candidate
from regen.falsify.proposals import Causes, propose_causes
from regen.falsify.record import (
    CANDIDATE_JSON,
    CANDIDATES,
    FALSIFY_JSON,
    CandidateRecord,
    Falsification,
    Finding,
    ModelRound,
    PolicyRun,
    ScriptedRun,
)
from regen.falsify.search import (
    DEFAULT_PARAM_BUDGET,
    default_out,
    failure_words,
    run_falsify,
    sources_of,
)
from regen.falsify.shrink import Shrunk, shrink
from regen.falsify.space import candidate_id, compatible, root_causes, single_edits

__all__ = ["CANDIDATES", "CANDIDATE_JSON", "DEFAULT_PARAM_BUDGET", "FALSIFY_JSON", "Bench", "CandidateRecord",
           "Causes", "Falsification", "Finding", "ModelRound", "PolicyRun", "ScriptedRun", "Shrunk", "Source",
           "candidate_id", "compatible", "default_out", "failure_words", "kept", "propose_causes",
           "replay_command", "root_causes", "run_candidate", "run_falsify", "shrink", "single_edits",
           "sources_of"]
