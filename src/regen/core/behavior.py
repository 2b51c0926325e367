"""The input of the whole pipeline: a robot behavior and its text.

What makes a behavior executable is the domain's business: ``Behavior.params`` holds the domain's
own parameters as JSON data, and the domain checks them with its :class:`BehaviorParams` model
(``DomainBackend.params_model``), which forbids keys it does not know.
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import Field, ValidationError, field_validator, model_validator

from regen.core.base import Model
from regen.core.text import one_line

#: Top-level behavior keys of files written before ``params`` existed (run.json, scenario.json,
#: path.json, tests.json, graph.json): their non-null values are read into ``params``, and
#: :meth:`Behavior.hash_layout` lays a behavior out as they did.
LEGACY_KEYS: tuple[str, ...] = ("ego_template", "route", "reward")


class Behavior(Model):
    """A robot behavior: its text, its domain, and the domain's parameters that make it executable
    (each domain names them in its ``params_model``)."""

    text: str = Field(description="Natural-language description, e.g. 'the robot opens the door'")
    domain: str = Field(min_length=1, description="A registered domain (regen.domains.names())")
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="The domain's own parameters (JSON data), checked by "
                                               "the domain's params model")

    @model_validator(mode="before")
    @classmethod
    def _old_layout(cls, data: Any) -> Any:
        # files written before params: the parameters were top-level keys, often null
        if isinstance(data, dict) and any(k in data for k in LEGACY_KEYS):
            data = dict(data)
            old = {k: data.pop(k) for k in LEGACY_KEYS if k in data}
            params = dict(data.get("params") or {})
            params.update({k: v for k, v in old.items() if v is not None and k not in params})
            data["params"] = params
        return data

    @field_validator("text")
    @classmethod
    def _text_not_empty(cls, v: str) -> str:
        # invisible characters (regen.core.text) would make two behaviors that read the same
        # differ, in prompts, cache keys and folder names
        v = one_line(v)
        if not v:
            raise ValueError("the behavior text is empty: describe the robot behavior, e.g. "
                             "'the robot opens the door'")
        if len(v) > 2000:
            raise ValueError("the behavior text is longer than 2000 characters: shorten it")
        return v

    def hash_layout(self) -> dict[str, Any]:
        """The behavior laid out as before ``params`` existed (the legacy keys at the top level,
        null when unset; other parameters, if any, under ``params``). Hashes of it (a cause
        path's key, hence scenario ids, folder names and seeds) stay what they were."""
        out: dict[str, Any] = {"text": self.text, "domain": self.domain}
        out.update({k: self.params.get(k) for k in LEGACY_KEYS})
        rest = {k: v for k, v in self.params.items() if k not in LEGACY_KEYS}
        if rest:
            out["params"] = rest
        return out


P = TypeVar("P", bound="BehaviorParams")


class BehaviorParams(Model):
    """Base of a domain's model of ``Behavior.params``: typed fields, unknown keys refused. This
    base has no fields: a domain that keeps it takes no parameters."""

    @classmethod
    def of(cls: type[P], behavior: Behavior) -> P:
        """The behavior's parameters as this model; :class:`ConfigError` naming the bad key."""
        from regen.errors import ConfigError

        try:
            return cls.model_validate(behavior.params)
        except ValidationError as exc:
            takes = ", ".join(cls.model_fields) or "no parameters"
            msgs = []
            for e in exc.errors():
                key = ".".join(str(x) for x in e["loc"]) or "params"
                if e["type"] == "extra_forbidden":
                    msgs.append(f"{behavior.domain} behaviors take no {key!r} (they take: {takes})")
                else:
                    msgs.append(f"{key} = {e.get('input')!r}: {str(e['msg']).removeprefix('Value error, ')}")
            raise ConfigError("bad behavior parameters: " + "; ".join(msgs)) from None

    def as_params(self) -> dict[str, Any]:
        """As ``Behavior.params``: JSON data, unset (None) parameters left out."""
        return {k: v for k, v in self.model_dump(mode="json").items() if v is not None}


def make_behavior(text: str, domain: str, **params: object) -> Behavior:
    """A behavior from user input, checked against its domain (a registered one, whose backend
    accepts it and its parameters) before any model call; ConfigError saying what to give
    otherwise. Parameters given as None are left out."""
    from regen import domains
    from regen.errors import ConfigError

    backend = domains.make(domain)  # an unknown domain names the choices
    given = {k: v for k, v in params.items() if v is not None}
    try:
        behavior = Behavior(text=text, domain=domain, params=given)
    except ValidationError as exc:
        msg = "; ".join(str(e["msg"]).removeprefix("Value error, ") for e in exc.errors())
        raise ConfigError(f"bad behavior: {msg}") from None
    backend.check_behavior(behavior)
    behavior.params = backend.params(behavior).as_params()
    return behavior
