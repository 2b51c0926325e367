"""``tests.json`` and ``junit.xml`` of a suite: one JUnit testcase per scenario variant, a
failure's message naming its cause (with the word "collision" when it is one)."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from regen.core.io import atomic_write_text, write_json
from regen.harness.cases import SuiteReport

#: Characters XML 1.0 forbids (controls other than tab and newlines, U+FFFE/U+FFFF) and lone
#: surrogates, which cannot even be encoded: a policy's message may hold any of them.
_NOT_XML = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def xml_safe(text: str) -> str:
    """``text`` with every character XML 1.0 forbids replaced by U+FFFD."""
    return _NOT_XML.sub("\ufffd", text)


def junit_xml(report: SuiteReport) -> str:
    """JUnit XML of a report: one testcase per scenario variant."""
    s = report.summary()
    wall = sum(c.wall for c in report.cases)
    root = ET.Element("testsuites", name="regen test", tests=str(len(report.cases)),
                      failures=str(s["failed"] - s["errors"]), errors=str(s["errors"]), skipped=str(s["skipped"]),
                      time=f"{wall:.3f}")
    suite = ET.SubElement(root, "testsuite", name=f"regen test --policy {report.policy}",
                          tests=str(len(report.cases)), failures=str(s["failed"] - s["errors"]), errors=str(s["errors"]),
                          skipped=str(s["skipped"]), time=f"{wall:.3f}")
    props = ET.SubElement(suite, "properties")
    for k, v in (("run", report.run), ("policy", report.policy), ("domain", report.domain),
                 ("oracle", report.oracle), ("seed", str(report.seed)), ("variants", str(report.variants)),
                 ("adversarial", str(report.adversarial).lower()),
                 ("collision_rate", report.collision_line().split(": ", 1)[1])):
        ET.SubElement(props, "property", name=k, value=v)
    for c in report.cases:
        tc = ET.SubElement(suite, "testcase", classname=f"regen.{report.domain or 'run'}.{Path(report.run).name}",
                           name=f"{c.scenario}[variant {c.variant}]", time=f"{c.wall:.3f}")
        values = [(f"{actor}.{k}", f"{v:g}") for actor, p in c.parameters.items() for k, v in p.items()]
        if c.template is not None:
            values.append(("template", c.template.status + (" with collision" if c.template.collision else "")))
        if values:  # the variant's parameters and the scripted robot's check
            tc_props = ET.SubElement(tc, "properties")
            for k, v in values:
                ET.SubElement(tc_props, "property", name=k, value=v)
        if c.status == "skipped":
            ET.SubElement(tc, "skipped", message=c.message)
        elif c.status == "failed":
            fail = ET.SubElement(tc, "error" if c.cause == "error" else "failure", message=c.message, type=c.cause or "failure")
            fail.text = json.dumps(c.model_dump(mode="json"), indent=2, ensure_ascii=False, default=str)
    ET.indent(root)
    body = xml_safe(ET.tostring(root, encoding="unicode"))  # a CI system must always read it
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def write_report(report: SuiteReport, out_dir: str | Path) -> dict[str, Path]:
    """``tests.json`` and ``junit.xml`` in ``out_dir`` (created)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    data = report.model_dump(mode="json")
    data["summary"] = report.summary()
    return {"tests": write_json(out / "tests.json", data),
            "junit": atomic_write_text(out / "junit.xml", junit_xml(report))}


__all__ = ["junit_xml", "write_report", "xml_safe"]
