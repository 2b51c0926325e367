"""Fixtures of the LLM tests."""

from fault_server import fault_server  # noqa: F401  (a fixture: tests ask for it by name)
