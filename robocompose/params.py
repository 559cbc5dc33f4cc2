"""params.yaml: reading sections into config dataclasses (checked), and switching profiles.

`profiles/default.yaml` holds every knob of the default profile; another profile (e.g.
`profiles/paper.yaml`) holds only what it changes. `robocompose profile NAME` writes their merge to
params.yaml, which is what DVC tracks.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")
PARAMS_FILE = "params.yaml"
PROFILES_DIR = "profiles"


def read_params(path: str | Path = PARAMS_FILE) -> dict:
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: params file not found (run `robocompose profile default` to write it)")
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except yaml.YAMLError as err:
        raise ValueError(f"{path}: not valid YAML: {err}") from None
    if not isinstance(document, dict):
        raise ValueError(f"{path}: expected a mapping of sections at the top level, found {type(document).__name__}")
    return document


def build_config(cls: type[T], values: Any, where: str) -> T:
    """Make dataclass `cls` from a mapping; unknown keys, wrong types and invalid values name `where.field`."""
    if not isinstance(values, dict):
        raise ValueError(f"{where}: expected a mapping with fields {[f.name for f in dataclasses.fields(cls)]}, "
                         f"found {values!r}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown field; expected one of {sorted(fields)}")
    for name, value in values.items():
        expected = fields[name].type if isinstance(fields[name].type, type) else _declared_type(fields[name])
        if expected is None:
            continue
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            continue
        if not isinstance(value, expected) or (expected in (int, float) and isinstance(value, bool)):
            raise ValueError(f"{where}.{name}: expected {expected.__name__}, found {value!r}")
    try:
        return cls(**values)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None


def _declared_type(f: dataclasses.Field) -> type | None:
    """The runtime type of a field annotated as a string (from __future__ annotations)."""
    name = str(f.type).split("[")[0].split("|")[0].strip()
    return {"int": int, "float": float, "str": str, "bool": bool, "list": list, "dict": dict}.get(name)


def load_section(cls: type[T], key: str, path: str | Path = PARAMS_FILE) -> T:
    """The section `key` (dotted for nesting, e.g. "enumerate") of a params file as `cls`."""
    node: Any = read_params(path)
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise ValueError(f"{path}: missing section {key!r}")
        node = node[part]
    return build_config(cls, node, f"{path}: {key}")


def merge(base: dict, override: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in override.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def write_profile(name: str, root: str | Path = ".") -> Path:
    """Write params.yaml = profiles/default.yaml merged with profiles/NAME.yaml."""
    from robocompose.io import atomic_write_text

    root = Path(root)
    base = read_params(root / PROFILES_DIR / "default.yaml")
    if name != "default":
        profile = root / PROFILES_DIR / f"{name}.yaml"
        if not profile.exists():
            known = sorted(p.stem for p in (root / PROFILES_DIR).glob("*.yaml"))
            raise FileNotFoundError(f"{profile}: no such profile; known profiles: {known}")
        base = merge(base, read_params(profile))
    header = (f"# Written by `robocompose profile {name}` from profiles/; edit the profile files, not this one.\n"
              f"profile: {name}\n")
    base.pop("profile", None)
    return atomic_write_text(root / PARAMS_FILE, header + yaml.safe_dump(base, sort_keys=False))
