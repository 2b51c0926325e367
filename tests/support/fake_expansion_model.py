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
                 otherwise: str | None = None, part_of: dict[str, bool] | None = None):
        self.causes = causes
        self.plausible = plausible or {}
        self.entities = entities or {}
        self.values = values or {}
        self.choose = choose or {}
        self.then = list(then or [])
        self.otherwise = otherwise
        self.part_of = part_of or {}  # entity asset -> the entity judge's answer (default yes)
        self.kinds: list[str] = []

    def __call__(self, messages) -> str:
        text = messages[-1]["content"]
        if "plausible events that could directly cause" in text:
            src = re.search(r'directly cause "(.*?)"', text).group(1)
            self.kinds.append("propose")
            return json.dumps({"causes": self.causes.get(src, [])})
        if "is a direct reason for the effect" in text:
            c = re.findall(r'^Candidate: "(.*)"$', text, re.M)[-1]  # the worked examples come first
            self.kinds.append("judge")
            return json.dumps({"answer": "yes" if self.plausible.get(c, True) else "no", "reason": f"because {c}"})
        if "Decide whether the entity takes part in the event" in text:
            asset = re.findall(r'^Entity: "(.*)" \(', text, re.M)[-1]  # the worked examples come first
            self.kinds.append("entity_judge")
            return json.dumps({"answer": "yes" if self.part_of.get(asset, True) else "no"})
        if "The simulator can only create these entities" in text:
            ev = re.search(r'Event: "(.*?)"', text).group(1)
            self.kinds.append("entities")
            return json.dumps({"entities": [{"name": n, "reason": "needed"} for n in self.entities.get(ev, [])]})
        if "possible values of" in text:
            props = re.findall(r'possible values of "(.*?)"', text)
            self.kinds.append("values")
            return json.dumps({p: self.values.get(p, []) for p in props})
        if "choose, for each property, the one value" in text:
            self.kinds.append("properties")
            return json.dumps({"role": "fits", "choice": self._choice(text)})
        if self.then:
            self.kinds.append("other")
            answer = self.then.pop(0)
            return answer if isinstance(answer, str) else json.dumps(answer)
        if self.otherwise is not None:
            self.kinds.append("other")
            return self.otherwise
        raise AssertionError("unexpected prompt: " + text[:200])

    def _choice(self, text: str) -> dict[str, str]:
        """One value per property: the scripted one (first of ``choose``) if offered, else the
        first offered; consistent with the prompt's rules for the key property's value."""
        offered = {p: [v.strip() for v in vals.split(" | ")]
                   for p, vals in re.findall(r"^- (\w+) \(.*?\): (.*)$", text, re.M)}
        found = re.findall(r"^- (\w+) = (\S+): (.*)$", text, re.M)
        rules: dict[tuple[str, str], str] = {}
        for k, v, rule in found:  # alternatives of one key value: the one that allows most wishes
            def fits(r: str) -> int:
                return sum(any(re.search(rf"\b{p} one of [^;]*\b{re.escape(w)}\b", r) for w in ws[:1])
                           for p, ws in self.choose.items())
            if (k, v) not in rules or fits(rule) > fits(rules[(k, v)]):
                rules[(k, v)] = rule
        out: dict[str, str] = {}
        key = next((k for k, _ in rules), None)
        order = sorted(offered, key=lambda p: p != key)
        for p in order:
            allowed = offered[p]
            if key is not None and p != key and (key, out.get(key)) in rules:
                rule = rules[(key, out[key])]
                if re.search(rf"\bno {p}\b", rule):
                    continue
                if m := re.search(rf"\b{p} one of ([^;]*)", rule):
                    allowed = [v.strip() for v in m.group(1).split(" | ")]
            wanted = [v for v in self.choose.get(p, []) if v in allowed]
            out[p] = wanted[0] if wanted else allowed[0]
        return out
