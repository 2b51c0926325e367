"""The dataset tests share hand-built scenarios (dataset_builders.py beside this file) and the
loopback model server (``fault_server``, tests/support)."""

from __future__ import annotations

import sys
from pathlib import Path

from fault_server import fault_server  # noqa: F401  (a fixture: tests ask for it by name)

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:  # importlib mode puts no test folder on the path
    sys.path.insert(0, HERE)
