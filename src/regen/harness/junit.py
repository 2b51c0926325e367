"""``tests.json`` and ``junit.xml`` of a suite: one JUnit testcase per scenario variant.

A failed testcase's ``message`` is the failure's reason (with the word "collision" when it is
one) and its body says, one fact a line, what happened, when, in which variant, and where its
picture and trace are. A testcase's ``<system-out>`` holds what the policy printed during it
(the tail of its part of ``policy.log``) and its failure picture in the attachments convention
Jenkins and GitLab read, a line ``[[ATTACHMENT|/absolute/path/failure.gif]]``.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from regen.core.io import atomic_write_text, write_json
from regen.harness.cases import CaseResult, SuiteReport
from regen.harness.pictures import TRACE_FILE, case_folder

#: Characters XML 1.0 forbids (controls other than tab and newlines, U+FFFE/U+FFFF) and lone
#: surrogates, which cannot even be encoded: a policy's message may hold any of them.
_NOT_XML = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def xml_safe(text: str) -> str:
    """``text`` with every character XML 1.0 forbids replaced by U+FFFD."""
    return _NOT_XML.sub("\ufffd", text)


def _when(c: CaseResult) -> str:
    ran = (f"the episode ran {c.simulated:.1f} s of simulated time" if c.simulated
           else "no simulated time was recorded")
    return f"t={c.collision_time:.1f} s ({ran})" if c.collision_time is not None else ran


def failure_text(c: CaseResult, out_dir: str | Path | None = None) -> str:
    """The body of a failed testcase: what happened, when, in which variant, and where its
    picture, trace and the whole record are (absolute paths when ``out_dir`` is known)."""
    base = Path(out_dir).absolute() if out_dir is not None else None
    lines = [f"what happened: {c.message or c.cause or 'failed'}", f"when: {_when(c)}",
             f"scenario: {c.scenario}, variant {c.variant}" + (" (adversarial search)" if c.adversarial else "")]
    if c.cause:
        lines.append(f"cause: {c.cause}")
    if c.collision_with:
        lines.append(f"collision with: {c.collision_with}")
    figures = [f"min TTC {c.min_ttc:.2f} s" if c.min_ttc is not None else "",
               f"min distance {c.min_distance:.2f} m" if c.min_distance is not None else ""]
    if any(figures):
        lines.append("closest approach: " + ", ".join(f for f in figures if f))
    if c.robot_stages:
        lines.append("expected states: " + "; ".join(
            f"{' and '.join(s.conditions)} " + (f"at t={s.reached_at:.1f} s" if s.reached_at is not None
                                               else "not reached") for s in c.robot_stages))
    lines += [f"other incident: {i}" for i in c.infractions]
    values = [f"{actor}.{k}={v:g}" for actor, p in c.parameters.items() for k, v in p.items()]
    if values:
        lines.append("parameters: " + ", ".join(values))
    if c.template is not None:
        lines.append(f"scripted robot in this variant: {c.template.status}"
                     + (" with a collision" if c.template.collision else ""))
    if c.causal:
        lines.append(f"causal check of the scenario: {c.causal}")
    if c.gif:
        lines.append(f"picture: {base / c.gif if base is not None else c.gif}")
    if base is not None and (base / case_folder(c) / TRACE_FILE).is_file():
        lines.append(f"trace: {base / case_folder(c) / TRACE_FILE}")
    lines.append(f"every field: {base / 'tests.json' if base is not None else 'tests.json'}")
    return "\n".join(lines)


def _system_out(c: CaseResult, log: str, out_dir: str | Path | None) -> str:
    """What the policy printed during the case, then its picture as a JUnit attachment."""
    parts = [f"policy output (the end of its part of policy.log):\n{log.rstrip()}"] if log.strip() else []
    if c.gif and out_dir is not None:
        parts.append(f"[[ATTACHMENT|{Path(out_dir).absolute() / c.gif}]]")
    return "\n".join(parts)


def junit_xml(report: SuiteReport, *, out_dir: str | Path | None = None,
              logs: Mapping[str, str] | None = None) -> str:
    """JUnit XML of a report: one testcase per scenario variant. ``out_dir``: the folder of
    tests.json (the paths in the XML are absolute then, and a failure picture is attached);
    ``logs``: what the policy printed during each case, by ``<scenario>-v<variant>``."""
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
            fail.text = failure_text(c, out_dir)
        printed = _system_out(c, (logs or {}).get(case_folder(c), ""), out_dir)
        if printed:
            ET.SubElement(tc, "system-out").text = printed
    ET.indent(root)
    body = xml_safe(ET.tostring(root, encoding="unicode"))  # a CI system must always read it
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def write_report(report: SuiteReport, out_dir: str | Path, *, logs: Mapping[str, str] | None = None
                 ) -> dict[str, Path]:
    """``tests.json`` and ``junit.xml`` in ``out_dir`` (created); ``logs`` as for :func:`junit_xml`."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    data = report.model_dump(mode="json")
    data["summary"] = report.summary()
    return {"tests": write_json(out / "tests.json", data),
            "junit": atomic_write_text(out / "junit.xml", junit_xml(report, out_dir=out, logs=logs))}


__all__ = ["failure_text", "junit_xml", "write_report", "xml_safe"]
