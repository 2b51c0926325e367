"""Grounding: a cause path becomes a manipulation scenario (the model's answer schemas and the
rules that stand in for a bad answer, CP-SAT placement of the context objects, the FSM).

Imports: ``world`` and ``assets`` of this domain, the shared core and the template loader.
"""
