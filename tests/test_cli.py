from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from regen.cli import app

runner = CliRunner()


def test_assets_json_lists_the_database() -> None:
    res = runner.invoke(app, ["assets", "driving", "--json"])
    assert res.exit_code == 0
    assert "ambulance" in json.loads(res.stdout)["assets"]


def test_bad_database_is_a_one_line_error_without_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "db.json"
    bad.write_text("{")
    res = runner.invoke(app, ["assets", str(bad)])
    assert res.exit_code == 2
    assert "error:" in res.output and "not valid JSON" in res.output
    assert "Traceback" not in res.output


def test_predicates_lists_units_unmangled() -> None:
    res = runner.invoke(app, ["predicates"])
    assert res.exit_code == 0 and "[m/s]" in res.output


def test_the_domain_help_lists_the_registered_domains() -> None:
    """No domain is written into the help: a domain registered before the CLI loads is listed."""
    import os
    import subprocess
    import sys

    from regen import domains

    res = runner.invoke(app, ["assets", "--help"])
    assert res.exit_code == 0 and all(n in res.output for n in domains.names())
    code = ("from regen import domains; domains.register('aisle', 'toydomain:AisleBackend'); "
            "from regen.cli import app; app(['assets', '--help'])")
    support = Path(__file__).resolve().parent / "support"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "COLUMNS": "200",
                              "PYTHONPATH": f"{support}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    assert "aisle, driving, manipulation" in out.stdout, out.stdout + out.stderr
