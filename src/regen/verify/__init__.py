"""The FSM monitor and the predicate library it evaluates on traces (shared by all simulators)."""

from regen.verify.monitor import check_fsm, validate_fsm
from regen.verify.predicates import PredicateSpec, get_predicate, list_predicates, predicate

__all__ = ["PredicateSpec", "check_fsm", "get_predicate", "list_predicates", "predicate", "validate_fsm"]
