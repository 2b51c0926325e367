"""The standard's own checkers over exported files: the ASAM Quality Checker bundles for
OpenDRIVE (``asam-qc-opendrive``) and OpenSCENARIO XML (``asam-qc-openscenarioxml``).

They pin other versions of numpy and lxml than this project, so ``setup.sh`` installs them into
a virtual environment of their own (``.venv-qc`` beside the checkout, or the folder named by
``REGEN_QC_VENV``). This module runs a bundle as a program on one file with a configuration it
writes, and reads the result file (``.xqar``, XML) it leaves: issue level 1 is an error, 2 a
warning, 3 information. Nothing here imports the checkers.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

from regen.errors import ConfigError, RegenError


class QcError(RegenError):
    """A checker that could not run on a file, or left no readable result."""


#: file suffix -> (the bundle's program, its bundle name)
BUNDLES = {".xodr": ("qc_opendrive", "xodrBundle"), ".xosc": ("qc_openscenario", "xoscBundle")}
LEVELS = {1: "error", 2: "warning", 3: "information"}
TIMEOUT = 300.0  # [s] per file


@dataclass
class QcIssue:
    checker: str
    level: str  # 'error', 'warning', 'information'
    description: str
    where: list[str] = field(default_factory=list)  # the locations' descriptions


@dataclass
class QcReport:
    """One file checked by its bundle."""

    file: str
    bundle: str
    completed: list[str] = field(default_factory=list)  # checkers that ran to the end
    skipped: dict[str, str] = field(default_factory=dict)  # checker -> why (the bundle's summary)
    failed: dict[str, str] = field(default_factory=dict)  # checkers with an internal error
    issues: list[QcIssue] = field(default_factory=list)

    @property
    def errors(self) -> list[QcIssue]:
        return [i for i in self.issues if i.level == "error"]

    def summary(self) -> str:
        return (f"{Path(self.file).name}: {len(self.completed)} checkers completed, {len(self.skipped)} skipped, "
                f"{len(self.failed)} failed; {len(self.errors)} errors, {len(self.issues) - len(self.errors)} other issues")


def qc_venv() -> Path:
    """The checkers' virtual environment: REGEN_QC_VENV, else ``.venv-qc`` of the checkout."""
    env = os.environ.get("REGEN_QC_VENV")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[4] / ".venv-qc"


def program(suffix: str) -> Path:
    """The bundle program for a file suffix; ConfigError saying how to get it."""
    name = BUNDLES[suffix][0]
    exe = qc_venv() / "bin" / name
    if not exe.is_file():
        raise ConfigError(f"the ASAM checker {name} is not installed ({exe} is missing): setup.sh installs "
                          "asam-qc-opendrive and asam-qc-openscenarioxml into .venv-qc, or point REGEN_QC_VENV "
                          "at a virtual environment that has them")
    return exe


def parse_result(path: str | Path) -> QcReport:
    """A ``.xqar`` result file as a report."""
    root = ET.parse(path).getroot()
    bundle = root.find("CheckerBundle")
    if bundle is None:
        raise QcError(f"{path}: no CheckerBundle in the checker's result")
    params = {p.get("name"): p.get("value") for p in bundle.findall("Param")}
    report = QcReport(file=str(params.get("InputFile", "")), bundle=str(bundle.get("name")))
    for c in bundle.findall("Checker"):
        cid, status = str(c.get("checkerId")), str(c.get("status"))
        if status == "completed":
            report.completed.append(cid)
        elif status == "skipped":
            report.skipped[cid] = str(c.get("summary", ""))
        else:
            report.failed[cid] = f"{status}: {c.get('summary', '')}"
        for i in c.findall("Issue"):
            where = [str(loc.get("description", "")) for loc in i.findall("Locations")]
            report.issues.append(QcIssue(checker=cid, level=LEVELS.get(int(i.get("level", "1")), "error"),
                                         description=str(i.get("description", "")), where=where))
    return report


def check_file(path: str | Path) -> QcReport:
    """Run the bundle of ``path``'s format (``.xodr`` or ``.xosc``) on it."""
    p = Path(path).absolute()
    if p.suffix not in BUNDLES:
        raise QcError(f"{p.name}: the ASAM checkers read .xodr and .xosc files")
    exe = program(p.suffix)
    with tempfile.TemporaryDirectory(prefix="regen-qc-") as tmp:
        result = Path(tmp) / "result.xqar"
        config = Path(tmp) / "config.xml"
        config.write_text(
            '<?xml version="1.0" encoding="UTF-8"?>\n<Config>\n'
            f'  <Param name="InputFile" value={quoteattr(str(p))}/>\n'
            f'  <CheckerBundle application="{BUNDLES[p.suffix][1]}">\n'
            f'    <Param name="resultFile" value={quoteattr(str(result))}/>\n'
            "  </CheckerBundle>\n</Config>\n", encoding="utf-8")
        try:
            done = subprocess.run([str(exe), "-c", str(config)], capture_output=True, text=True, timeout=TIMEOUT,
                                  cwd=tmp, check=False)
        except subprocess.TimeoutExpired:
            raise QcError(f"{p.name}: the {BUNDLES[p.suffix][1]} checker did not finish in {TIMEOUT:g} s") from None
        if not result.is_file():
            tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
            raise QcError(f"{p.name}: the {BUNDLES[p.suffix][1]} checker wrote no result "
                              f"(exit {done.returncode}: {tail[0]})")
        return parse_result(result)


__all__ = ["BUNDLES", "QcError", "QcIssue", "QcReport", "check_file", "parse_result", "program", "qc_venv"]
