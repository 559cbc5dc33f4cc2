"""params.yaml: the one loader of every stage and command, and switching profiles.

    config = load_section(GLSOConfig, "glso")        # a section (dotted: "train_vae.extra") as its dataclass

`build_config` checks a mapping against a dataclass's annotations (nested dataclass sections too) and its
`__post_init__`; every bad value is one InputError line naming the file, the field, the value and what was
expected. `profiles/default.yaml` holds every knob of the default profile; another profile (e.g.
`profiles/paper.yaml`) holds only what it changes. `robocompose profile NAME` checks every section of their
merge (`SECTIONS`) and writes it to params.yaml, which is what DVC tracks.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import math
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

import yaml

from robocompose.io.errors import InputError, shown

T = TypeVar("T")
PARAMS_FILE = "params.yaml"
PROFILES_DIR = "profiles"
# The config dataclass of every section, by (module, class) name: imported only to check a profile, so the
# stages that read one section do not depend on every world's code.
SECTIONS = {
    "compute": ("robocompose.fanout.compute", "ComputeConfig"),
    "enumerate": ("robocompose.dataset.enumerate", "EnumerateConfig"),
    "nogram": ("robocompose.dataset.nogram", "NogramConfig"),
    "gallery": ("robocompose.dataset.summary", "GalleryConfig"),
    "teams": ("robocompose.teams.params", "TeamsParams"),
    "evaluation": ("robocompose.evaluation.evaluate", "EvaluationConfig"),
    "evaluate_references": ("robocompose.evaluation.references", "ReferencesConfig"),
    "evaluator_fidelity": ("robocompose.evaluation.fidelity", "FidelityConfig"),
    "modular": ("robocompose.modular.params", "ModularParams"),
    "eggan_modular": ("robocompose.modular.eggan_params", "EgganModularParams"),
    "train_vae": ("robocompose.latent.params", "TrainVaeParams"),
    "train_vae.landscape": ("robocompose.latent.landscape", "LandscapeConfig"),
    "glso": ("robocompose.glso.runs", "GLSOConfig"),
    "glso_campaign": ("robocompose.glso.campaign", "CampaignConfig"),
    "vae_thesis": ("robocompose.latent.thesis_scale", "ThesisScaleConfig"),
}


class _AliasFound(yaml.YAMLError):
    def __init__(self, mark: Any) -> None:
        super().__init__(f"line {mark.line + 1}, column {mark.column + 1}")


class _PlainLoader(yaml.SafeLoader):
    """SafeLoader without anchors and aliases: a few lines of nested aliases (a "billion laughs") expand to
    gigabytes, and a params file never needs them."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            raise _AliasFound(event.start_mark)
        return super().compose_node(parent, index)


class _PlainDumper(yaml.SafeDumper):
    """SafeDumper that writes a value shared by two keys twice, never as an anchor and an alias."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def load_yaml(text: str, where: str | Path) -> Any:
    """The document of YAML `text` read from `where` (a user's file): safe types only, no anchors or aliases;
    InputError naming `where` otherwise."""
    try:
        return yaml.load(text, Loader=_PlainLoader)  # noqa: S506 (a SafeLoader)
    except _AliasFound as err:
        raise InputError(f"{where}: YAML anchors and aliases are not allowed (&name / *name at {err})") from None
    except yaml.YAMLError as err:
        raise InputError(f"{where}: not valid YAML: {err}") from None


def dump_yaml(document: Any) -> str:
    """`document` as YAML that `load_yaml` reads back (no anchors or aliases)."""
    return yaml.dump(document, Dumper=_PlainDumper, sort_keys=False)


def read_params(path: str | Path = PARAMS_FILE) -> dict:
    path = Path(path)
    if not path.is_file():
        found = "is a directory" if path.is_dir() else "not found"
        raise InputError(f"{path}: params file {found} (in the repository's root, `robocompose profile default` "
                         f"writes params.yaml)")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not valid YAML: not UTF-8 text ({err.reason} at byte {err.start})") from None
    document = load_yaml(text, path) or {}
    if not isinstance(document, dict):
        raise InputError(f"{path}: expected a mapping of sections at the top level, found {type(document).__name__}")
    return document


_TYPES = {int, float, str, bool, list, dict}


def _matches(value: Any, expected: type) -> bool:
    """YAML value vs a declared scalar type: an int is a float, a bool is not a number."""
    if expected in (int, float) and isinstance(value, bool):
        return False
    return isinstance(value, expected) or (expected is float and isinstance(value, int))


def build_config(cls: type[T], values: Any, where: str, complete: bool = False,
                 _deferred: list[str] | None = None) -> T:
    """Make dataclass `cls` from a mapping; unknown keys, wrong types and invalid values name `where.field`.

    Types are checked from the annotations (int, float, str, bool, list[...] item types); a field whose type
    is a dataclass (or dict[str, dataclass]) is built from its mapping the same way; value ranges are checked
    by the dataclass's own __post_init__, whose InputError("field: ...") is reported as `where.field: ...`.
    A field without a default must be given; with `complete` (a params file: `load_section`, `check_params`)
    so must every section (a dataclass field), defaults or not: a deleted section is an error naming it, never
    a silent fallback to the dataclass's defaults. Every float must be finite. These two general rules are
    reported after the classes' own checks (of the whole tree), which say more about what they expected.
    """
    deferred: list[str] = [] if _deferred is None else _deferred
    fields = {f.name: f for f in dataclasses.fields(cls)}
    if not isinstance(values, dict):
        raise InputError(f"{where}: expected a mapping with fields {list(fields)}, found {shown(values)}")
    unknown = sorted(set(values) - set(fields), key=str)
    if unknown:
        key = unknown[0] if isinstance(unknown[0], str) and len(unknown[0]) <= 80 else shown(unknown[0])
        raise InputError(f"{where}.{key}: unknown field; expected one of {sorted(fields)}")
    hints = typing.get_type_hints(cls)
    built = {name: _value(hints[name], value, f"{where}.{name}", complete, deferred)
             for name, value in values.items()}
    required = [name for name, f in fields.items() if name not in values and f.default is dataclasses.MISSING
                and f.default_factory is dataclasses.MISSING]  # named after the bad values of the given fields
    for name in required:
        kind = "section" if dataclasses.is_dataclass(hints[name]) else "field"
        raise InputError(f"{where}.{name}: missing {kind} (required; expected fields {list(fields)})")
    try:
        config = cls(**built)
    except (ValueError, TypeError) as err:
        message = str(err)
        joined = "." if message.split(":")[0].split(".")[0] in fields else ": "
        raise InputError(f"{where}{joined}{message}") from None
    for name, value in values.items():  # after the class's own checks, which say which range they expected
        items = value if isinstance(value, list) else value.values() if isinstance(value, dict) else [value]
        if _holds_floats(hints[name]) and any(
                isinstance(v, float) and not math.isfinite(v) for v in items):
            deferred.append(f"{where}.{name}: expected finite numbers (NaN and infinity give no right answer), "
                            f"found {shown(value)}")
    deferred += [f"{where}.{name}: missing section (a params file names every section, `{{}}` for its defaults)"
                 for name in fields if complete and name not in values and dataclasses.is_dataclass(hints[name])]
    if _deferred is None and deferred:  # the outermost section: every class's own checks have passed
        raise InputError(deferred[0])
    return config


def _holds_floats(hint: Any) -> bool:
    """Whether annotation `hint` is float or holds floats (list[float], float | None, ...)."""
    return hint is float or any(_holds_floats(arg) for arg in typing.get_args(hint))


def _value(hint: Any, value: Any, where: str, complete: bool = False, deferred: list[str] | None = None) -> Any:
    """`value` checked against annotation `hint` (nested dataclasses built); other annotations pass unchecked."""
    if dataclasses.is_dataclass(hint):
        return build_config(hint, value, where, complete, deferred)
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):  # X | None: None, or an X
        return None if value is None and type(None) in args else _value(args[0], value, where, complete, deferred)
    if origin is dict and len(args) == 2 and dataclasses.is_dataclass(args[1]):
        if not isinstance(value, dict):
            raise InputError(f"{where}: expected a mapping of name -> {args[1].__name__} fields, found {shown(value)}")
        return {key: build_config(args[1], item, f"{where}.{key}", complete, deferred) for key, item in value.items()}
    expected = origin or hint
    if expected in _TYPES and not _matches(value, expected):
        raise InputError(f"{where}: expected {expected.__name__}, found {shown(value)}")
    if expected is list and args and args[0] in _TYPES and not all(_matches(v, args[0]) for v in value):
        raise InputError(f"{where}: expected a list of {args[0].__name__}, found {shown(value)}")
    return value


def load_section(cls: type[T], key: str, path: str | Path = PARAMS_FILE) -> T:
    """The section `key` (dotted for nesting, e.g. "train_vae.extra") of a params file as `cls`: the one
    loader of every stage and command."""
    node: Any = read_params(path)
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise InputError(f"{path}: missing section {key!r} (`robocompose profile NAME` writes every section)")
        node = node[part]
    return build_config(cls, node, f"{path}: {key}", complete=True)


def load_command_section(cls: type[T], key: str, path: str | Path | None) -> T:
    """A command's section: from `path` (a --params file, which must exist); with None, from params.yaml if
    there is one, else the dataclass defaults."""
    if path is None:
        if not Path(PARAMS_FILE).exists():
            return cls()
        path = PARAMS_FILE
    return load_section(cls, key, path)


def merge(base: dict, override: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in override.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def check_params(document: dict, where: str) -> None:
    """Every section of a params document loads through `build_config` (and no section is unknown or missing)."""
    top = [key for key in SECTIONS if "." not in key]
    unknown = sorted(set(document) - set(top) - {"profile"}, key=str)
    if unknown:
        raise InputError(f"{where}: unknown section {shown(unknown[0])}; expected sections {top}")
    for key, (module, name) in SECTIONS.items():
        node: Any = document
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                raise InputError(f"{where}: missing section {key!r}")
            node = node[part]
        build_config(getattr(importlib.import_module(module), name), node, f"{where}: {key}", complete=True)


def profile_names(root: str | Path = ".") -> list[str]:
    return sorted(p.stem for p in (Path(root) / PROFILES_DIR).glob("*.yaml"))


def write_profile(name: str, root: str | Path = ".") -> Path:
    """Write params.yaml = profiles/default.yaml merged with profiles/NAME.yaml, after checking every section."""
    from robocompose.io import atomic_write_text

    root = Path(root)
    if not (root / PROFILES_DIR / "default.yaml").is_file():
        raise InputError(f"{(root / PROFILES_DIR).resolve()}: no default.yaml here; run `robocompose profile` in "
                         f"the repository's root folder (the one holding profiles/ and dvc.yaml)")
    target = root / PARAMS_FILE
    if target.exists() and not target.is_file():  # os.replace cannot put a file there
        raise InputError(f"{target}: not a file (a directory?); `robocompose profile` writes params.yaml there: "
                         "move it away first")
    known = profile_names(root)
    if name not in known:
        raise InputError(f"profile {shown(name)}: no such profile; expected one of {known} (the files in "
                         f"{root / PROFILES_DIR})")
    base = read_params(root / PROFILES_DIR / "default.yaml")
    if name != "default":
        base = merge(base, read_params(root / PROFILES_DIR / f"{name}.yaml"))
    base.pop("profile", None)
    check_params(base, f"{root / PROFILES_DIR / name}.yaml merged onto default.yaml")
    header = (f"# Written by `robocompose profile {name}` from profiles/; edit the profile files, not this one.\n"
              f"profile: {name}\n")
    return atomic_write_text(target, header + dump_yaml(base))
