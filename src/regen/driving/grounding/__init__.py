"""Grounding: a cause path becomes a driving scenario (rule grounding, model grounding and its
answer schemas, FSM rules, feasibility rules, CP-SAT placement).

Imports: ``world`` and ``primitives`` of this domain, the shared core, expand-free llm and verify.
"""
