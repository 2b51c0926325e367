"""The report's "Falsification" section: what ``regen falsify`` left in ``RUN/falsify/<policy>/``,
read as plain JSON (a broken file is named, a picture outside its folder is not linked)."""

from __future__ import annotations

import re

from regen.core.io import write_json
from regen.report import load_run, write_report
from regen.runfolder import read_falsify


def _search(folder: str, gif: str | None) -> dict:
    cid = "abc1234567"
    cand = {"cid": cid, "scenario": "01-cause-1", "tests": f"candidates/{cid}/tests/{folder}/tests.json",
            "xosc": f"candidates/{cid}/scenarios/{cid}/scenario.xosc",
            "policy": {"status": "failed", "gif": gif, "min_ttc": 0.0}}
    finding = {"cid": cid, "scenario": "01-cause-1", "edits": ["set sedan1.brake_lights = broken"],
               "failure": "collision with sedan1 at 4.1 s", "minimal": True, "by_model": False,
               "scripted": {"status": "verified", "verified": True, "causal": "caused"},
               "replay": f"regen test RUN/falsify/{folder}/candidates/{cid} --policy {folder}"}
    return {"policy": folder, "status": "done", "budget": 24, "tried": 30, "simulated": 24, "invalid": 11, "failures": 3,
            "errors": 0, "wall": 81.5, "parameter_search": "parameter search ran for 1 minimal finding",
            "candidates": [cand], "findings": [finding]}


def test_the_section_lists_each_policy_s_search_and_findings(make_run):
    run = make_run([{}])
    base = run / "falsify" / "idm"
    cid = "abc1234567"
    (base / "candidates" / cid / "tests" / "idm" / f"{cid}-v0").mkdir(parents=True)
    (base / "candidates" / cid / "tests" / "idm" / f"{cid}-v0" / "failure.gif").write_bytes(b"GIF89a")
    (base / "candidates" / cid / "tests" / "idm" / "tests.json").write_text("{}")
    write_json(base / "falsify.json", _search("idm", f"candidates/{cid}/tests/idm/{cid}-v0/failure.gif"))
    write_json(run / "falsify" / "aeb" / "falsify.json", _search("aeb", "../../../../secret.gif"))
    safety = {**_search("idm", None), "settings": {"oracle": "safety"}}  # a second search of idm, --out
    write_json(run / "falsify" / "idm-safety" / "falsify.json", safety)
    (run / "falsify" / "broken").mkdir()
    (run / "falsify" / "broken" / "falsify.json").write_text("{not json", encoding="utf-8")
    assert sorted(read_falsify(run)) == ["aeb", "broken", "idm", "idm-safety"]
    view = load_run(run)
    aeb, broken, idm, idm_safety = view.falsify
    assert (idm.oracle, idm_safety.oracle, idm_safety.policy) == ("", "safety", "idm")
    assert broken.problem.startswith("unreadable") and not broken.findings
    assert (idm.simulated, idm.invalid, idm.ungrounded, idm.failures, idm.budget) == (24, 5, 6, 3, 24)
    (f,) = idm.findings
    assert f.gif == f"falsify/idm/candidates/{cid}/tests/idm/{cid}-v0/failure.gif"
    assert f.tests and f.xosc is None  # the xosc file is not there: not linked
    assert f.anchor == "scenario-1" and f.number == 1 and f.minimal and f.scripted == "verified, caused"
    assert aeb.findings[0].gif is None  # outside its folder: never linked
    html = write_report(run).read_text(encoding="utf-8")
    assert 'href="#falsify"' in html and 'id="falsify"' in html
    assert "set sedan1.brake_lights = broken" in html and "collision with sedan1 at 4.1 s" in html
    assert f"regen test RUN/falsify/idm/candidates/{cid} --policy idm" in html
    assert f'src="falsify/idm/candidates/{cid}/tests/idm/{cid}-v0/failure.gif"' in html
    assert not re.search(r'src="[^"]*secret', html)
    # two searches of one policy tell apart by their oracle and folder
    assert "<td>safety</td>" in html and "falsify/idm-safety" in html and "Findings of idm (safety oracle)" in html


def test_no_falsify_folder_no_section(make_run):
    run = make_run([{}])
    assert load_run(run).falsify == []
    html = write_report(run).read_text(encoding="utf-8")
    assert 'id="falsify"' not in html
