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

from robocompose.io.errors import InputError

T = TypeVar("T")
PARAMS_FILE = "params.yaml"
PROFILES_DIR = "profiles"


def read_params(path: str | Path = PARAMS_FILE) -> dict:
    path = Path(path)
    if not path.is_file():
        found = "is a directory" if path.is_dir() else "not found"
        raise InputError(f"{path}: params file {found} (in the repository's root, `robocompose profile default` "
                         f"writes params.yaml)")
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: not valid YAML: {err}") from None
    if not isinstance(document, dict):
        raise InputError(f"{path}: expected a mapping of sections at the top level, found {type(document).__name__}")
    return document


_TYPES = {"int": int, "float": float, "str": str, "bool": bool, "list": list, "dict": dict}


def _matches(value: Any, expected: type) -> bool:
    """YAML value vs a declared scalar type: an int is a float, a bool is not a number."""
    if expected in (int, float) and isinstance(value, bool):
        return False
    return isinstance(value, expected) or (expected is float and isinstance(value, int))


def build_config(cls: type[T], values: Any, where: str) -> T:
    """Make dataclass `cls` from a mapping; unknown keys, wrong types and invalid values name `where.field`.

    Types are checked from the annotations (int, float, str, bool, list[...] item types); value ranges by the
    dataclass's own __post_init__, whose InputError("field: ...") is reported as `where.field: ...`.
    """
    names = [f.name for f in dataclasses.fields(cls)]
    if not isinstance(values, dict):
        raise InputError(f"{where}: expected a mapping with fields {names}, found {values!r}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - set(fields), key=str)
    if unknown:
        raise InputError(f"{where}.{unknown[0]}: unknown field; expected one of {sorted(fields)}")
    for name, value in values.items():
        expected, item = _declared_type(fields[name])
        if expected is not None and not _matches(value, expected):
            raise InputError(f"{where}.{name}: expected {expected.__name__}, found {value!r}")
        if item is not None and not all(_matches(v, item) for v in value):
            raise InputError(f"{where}.{name}: expected a list of {item.__name__}, found {value!r}")
    try:
        return cls(**values)
    except (ValueError, TypeError) as err:
        message = str(err)
        joined = "." if message.split(":")[0] in fields else ": "
        raise InputError(f"{where}{joined}{message}") from None


def _declared_type(f: dataclasses.Field) -> tuple[type | None, type | None]:
    """(runtime type, list item type) of a field's annotation, e.g. "list[int]" -> (list, int); None if other."""
    if isinstance(f.type, type):
        return f.type, None
    text = str(f.type).split("|")[0].strip()
    outer, _, inner = text.partition("[")
    return _TYPES.get(outer.strip()), (_TYPES.get(inner.rstrip("]").strip()) if outer.strip() == "list" else None)


def load_section(cls: type[T], key: str, path: str | Path = PARAMS_FILE) -> T:
    """The section `key` (dotted for nesting, e.g. "enumerate") of a params file as `cls`."""
    node: Any = read_params(path)
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise InputError(f"{path}: missing section {key!r}")
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
    if not (root / PROFILES_DIR / "default.yaml").is_file():
        raise InputError(f"{(root / PROFILES_DIR).resolve()}: no default.yaml here; run `robocompose profile` in "
                         f"the repository's root folder (the one holding profiles/ and dvc.yaml)")
    base = read_params(root / PROFILES_DIR / "default.yaml")
    if name != "default":
        profile = root / PROFILES_DIR / f"{name}.yaml"
        if not profile.exists():
            known = sorted(p.stem for p in (root / PROFILES_DIR).glob("*.yaml"))
            raise InputError(f"{profile}: no such profile; known profiles: {known}")
        base = merge(base, read_params(profile))
    header = (f"# Written by `robocompose profile {name}` from profiles/; edit the profile files, not this one.\n"
              f"profile: {name}\n")
    base.pop("profile", None)
    return atomic_write_text(root / PARAMS_FILE, header + yaml.safe_dump(base, sort_keys=False))
