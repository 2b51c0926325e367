"""The architecture as a machine checks it: no import cycle, the import-linter contracts in
pyproject.toml have teeth, the driving package is laid out by stage, files stay small and no
product module is named like a test."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "regen"
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")

grimp = pytest.importorskip("grimp", reason="the dev extra installs import-linter and grimp")


def _graph():
    import networkx as nx

    g = grimp.build_graph("regen", include_external_packages=False, exclude_type_checking_imports=True)
    G = nx.DiGraph()
    for m in g.modules:
        for d in g.find_modules_directly_imported_by(m):
            G.add_edge(m, d)
    return G


def test_no_import_cycle_among_regen_modules() -> None:
    import networkx as nx

    cycles = [c for c in nx.simple_cycles(_graph()) if len(c) > 1]
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c + c[:1]) for c in cycles[:5])


def _lint(src_root: Path) -> subprocess.CompletedProcess:
    """lint-imports with the project's contracts over the ``regen`` package found in src_root."""
    return subprocess.run([str(LINT_IMPORTS), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
                          cwd=src_root, capture_output=True, text=True, timeout=300,
                          env={"PYTHONPATH": str(src_root), "PATH": "/usr/bin:/bin"})


@pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="lint-imports comes with the dev extra")
def test_a_planted_upward_import_breaks_the_contract(tmp_path: Path) -> None:
    """The contract passes on the tree, and fails once a shared package imports a domain."""
    tree = tmp_path / "src"
    shutil.copytree(SRC, tree / "regen", ignore=shutil.ignore_patterns("__pycache__", "data", "*.j2"))
    assert _lint(tree).returncode == 0, _lint(tree).stdout[-2000:]
    planted = tree / "regen" / "verify" / "planted.py"
    planted.write_text("import regen.driving.backend  # noqa: F401\n")
    result = _lint(tree)
    assert result.returncode != 0
    assert "regen.verify.planted -> regen.driving.backend" in result.stdout


STAGES = {"world", "primitives", "grounding", "simulation", "verify", "render", "interop", "testing", "gym"}


def test_driving_holds_only_its_stages() -> None:
    here = SRC / "driving"
    modules = {p.name for p in here.glob("*.py")}
    packages = {p.name for p in here.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert modules == {"__init__.py", "backend.py", "assets.py"}
    assert packages == STAGES
    for stage in packages:  # each says what it holds and what it may import
        doc = (here / stage / "__init__.py").read_text()
        assert doc.startswith('"""') and "Imports" in doc, stage


MANIPULATION_STAGES = {"world", "grounding", "simulation", "verify", "render", "export", "testing", "gym"}


def test_manipulation_holds_only_its_stages() -> None:
    import ast

    here = SRC / "manipulation"
    modules = {p.name for p in here.glob("*.py")}
    packages = {p.name for p in here.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert modules == {"__init__.py", "backend.py", "assets.py"}
    assert packages == MANIPULATION_STAGES
    for stage in packages:  # each says what it holds and what it may import, and defines nothing
        doc = (here / stage / "__init__.py").read_text()
        assert doc.startswith('"""') and "Imports" in doc, stage
        defined = [n for n in ast.walk(ast.parse(doc))
                   if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))]
        assert not defined, stage


def test_no_source_file_over_500_lines() -> None:
    long = {str(p.relative_to(SRC)): n for p in SRC.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 500}
    assert not long, long


def test_no_product_module_or_class_named_like_a_test() -> None:
    named = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
             if p.name.startswith("test_") or p.stem.endswith("_test")]
    classes = [f"{p.relative_to(SRC)}: {m.group(1)}" for p in SRC.rglob("*.py")
               for m in re.finditer(r"^class (Test\w*)", p.read_text(encoding="utf-8"), re.M)]
    assert not named and not classes, named + classes


MAX_FUNCTION_LINES = 80


def test_no_function_over_80_lines() -> None:
    import ast

    long = [f"{p.relative_to(SRC)}:{n.lineno} {n.name} ({n.end_lineno - n.lineno + 1} lines)"
            for p in sorted(SRC.rglob("*.py")) for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and n.end_lineno - n.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, "functions over 80 lines: " + "; ".join(long)


def test_package_inits_only_reexport() -> None:
    import ast

    defining = [f"{p.relative_to(SRC)}:{n.lineno} {n.name}"
                for p in sorted(SRC.rglob("__init__.py")) for n in ast.parse(p.read_text(encoding="utf-8")).body
                if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))]
    assert not defining, "package __init__ files that define functions or classes: " + "; ".join(defining)


def test_no_module_imports_a_private_name_of_another() -> None:
    import ast

    private = [f"{p.relative_to(SRC)}:{n.lineno} {n.module}.{a.name}"
               for p in sorted(SRC.rglob("*.py")) for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
               if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("regen")
               for a in n.names if a.name.startswith("_") and not a.name.startswith("__")]
    assert not private, "private names imported from another module: " + "; ".join(private)
