"""A scripted model for expansion tests: answers depend on which prompt it is given."""

from __future__ import annotations

import json
import re


class ScriptedModel:
    """Maps (prompt kind, source text) to an answer; records the calls it saw. Prompts that are
    not expansion prompts (grounding) get ``then`` answers in order, else ``otherwise``."""

    def __init__(self, causes: dict[str, list[str]], plausible: dict[str, bool] | None = None,
                 entities: dict[str, list[str]] | None = None, values: dict[str, list[str]] | None = None,
                 choose: dict[str, list[str]] | None = None, then: list | None = None,
                 otherwise: str | None = None):
        self.causes = causes
        self.plausible = plausible or {}
        self.entities = entities or {}
        self.values = values or {}
        self.choose = choose or {}
        self.then = list(then or [])
        self.otherwise = otherwise
        self.kinds: list[str] = []

    def __call__(self, messages) -> str:
        text = messages[-1]["content"]
        if "plausible events that could directly cause" in text:
            src = re.search(r'directly cause "(.*?)"', text).group(1)
            self.kinds.append("propose")
            return json.dumps({"causes": self.causes.get(src, [])})
        if "Candidate causes:" in text:
            cands = re.findall(r"^\d+\. (.*)$", text, re.M)
            self.kinds.append("judge")
            return json.dumps({"decisions": [
                {"candidate": c, "plausible": self.plausible.get(c, True), "reason": f"because {c}"}
                for c in cands]})
        if "The simulator can only create these entities" in text:
            ev = re.search(r'Event: "(.*?)"', text).group(1)
            self.kinds.append("entities")
            return json.dumps({"entities": [{"name": n, "reason": "needed"} for n in self.entities.get(ev, [])]})
        if "possible values of" in text:
            props = re.findall(r'possible values of "(.*?)"', text)
            self.kinds.append("values")
            return json.dumps({p: self.values.get(p, []) for p in props})
        if "choose the value(s)" in text:
            props = re.findall(r"^- (\w+) \(", text, re.M)
            self.kinds.append("properties")
            out = {p: self.choose.get(p, []) for p in props}
            out["reason"] = "fits"
            return json.dumps(out)
        if self.then:
            self.kinds.append("other")
            answer = self.then.pop(0)
            return answer if isinstance(answer, str) else json.dumps(answer)
        if self.otherwise is not None:
            self.kinds.append("other")
            return self.otherwise
        raise AssertionError("unexpected prompt: " + text[:200])
