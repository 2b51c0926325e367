"""ReGen: generative robot simulation via inverse design.

The core (data model, asset databases, LLM layer, CP-SAT helpers, FSM monitor) imports no
simulator and no model runtime; those live behind extras and are imported lazily.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
