"""Loading the user's policy from a SPEC: a built-in name, ``module:callable`` or
``path/to/file.py[:callable]`` (the callable defaults to ``policy``)."""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType

from regen.errors import ConfigError


def _from_file(path: Path) -> ModuleType:
    if path.is_dir():
        raise ConfigError(f"policy file {path} is a folder: give path/to/file.py[:callable]")
    if not path.is_file():
        raise ConfigError(f"policy file {path} does not exist")
    mod_name = f"regen_user_policy_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(mod_name, path)
    if spec is None or spec.loader is None:
        raise ConfigError(f"cannot import {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module  # dataclasses and pickling look modules up by name
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        del sys.modules[mod_name]
        raise ConfigError(f"importing policy file {path} failed: {type(exc).__name__}: {exc}") from exc
    return module


def load_callable(spec: str, builtin: Mapping[str, Callable[[], object]]) -> Callable:
    """The policy a SPEC names. A built-in (``builtin[name]()``) and a class are instantiated;
    ConfigError saying what to give if the SPEC names nothing callable."""
    spec = spec.strip()
    if spec in builtin:
        return builtin[spec]()  # type: ignore[return-value]
    if spec.endswith(".py"):
        spec = f"{spec}:policy"
    if ":" not in spec:
        raise ConfigError(f"unknown policy {spec!r}: use a built-in name ({', '.join(builtin)}), "
                          "module:callable or path/to/file.py[:callable]")
    where, _, attr = spec.rpartition(":")
    if where.endswith(".py") or "/" in where or "\\" in where:
        module = _from_file(Path(where).expanduser())
    else:
        try:
            module = importlib.import_module(where)
        except ImportError as exc:
            raise ConfigError(f"cannot import policy module {where!r}: {exc}") from exc
    obj: object = module
    for part in attr.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            raise ConfigError(f"{where} has no attribute {attr!r}")
    if isinstance(obj, type):
        obj = obj()
    if not callable(obj):
        raise ConfigError(f"{spec} is not callable")
    return obj


__all__ = ["load_callable"]
