"""The core installs light: importing it must not pull simulators or model runtimes."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ["torch", "scenic", "pybullet", "llama_cpp", "stable_baselines3", "ray", "onnxruntime"]


def test_core_imports_leave_heavy_packages_unimported() -> None:
    code = (
        "import sys, json\n"
        "import regen, regen.core, regen.assets, regen.llm, regen.verify, regen.domains, regen.cli\n"
        "from regen.assets.database import database_of as database\n"
        "database('driving'); database('manipulation')\n"
        "from regen.verify import list_predicates\n"
        "list_predicates()\n"
        f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
