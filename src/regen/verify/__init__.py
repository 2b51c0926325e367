"""The FSM monitor and the predicate library it evaluates on traces (shared by all simulators)."""

from regen.verify.monitor import check_fsm, validate_fsm
from regen.verify.predicates import PredicateSpec, get_predicate, list_predicates, predicate
from regen.verify.relax import relax_fsm, verify_with_relaxation

__all__ = ["PredicateSpec", "check_fsm", "get_predicate", "list_predicates", "predicate", "relax_fsm",
           "validate_fsm", "verify_with_relaxation"]
