"""What code a result came from: a module's import closure inside the project, and a digest of its source.

Cache and checkpoint keys include `code_digest(...)` of the modules that compute the result, so a change
of code invalidates them with no version to bump by hand; the DVC deps test uses `import_closure` to
check that each stage lists every project module it imports.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import importlib
import inspect
import json
from pathlib import Path
from typing import Any

PACKAGE = "robocompose"
PACKAGE_DIR = Path(__file__).resolve().parents[1]  # .../robocompose
ROOT = PACKAGE_DIR.parent


def module_path(name: str) -> Path | None:
    """The source file of project module `name` (a package's `__init__.py`), or None if it is not one."""
    if name != PACKAGE and not name.startswith(PACKAGE + "."):
        return None
    base = ROOT.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _imported_names(path: Path, module: str) -> set[str]:
    """Project modules named by the import statements of one file (function-level imports included)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)  # `from pkg import submodule`
    return {n for n in names if module_path(n) is not None}


def _with_parents(name: str) -> list[str]:
    """A module and the packages above it: importing `a.b.c` runs `a/__init__`, `a/b/__init__` too."""
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts) + 1)]


@functools.cache
def import_closure(*entries: str | Path) -> tuple[Path, ...]:
    """Every project source file that importing the given modules or scripts runs, sorted.

    An entry is a module name (`robocompose.grammar.tree`) or the path of a script (`stages/enumerate.py`),
    whose own file is not part of the result.
    """
    stack: list[str] = []
    for entry in entries:
        if isinstance(entry, Path) or str(entry).endswith(".py"):
            stack += _imported_names(Path(entry), "__main__")
        else:
            stack.append(str(entry))
    seen: dict[str, Path] = {}
    while stack:
        name = stack.pop()
        path = module_path(name)
        if name in seen or path is None:
            continue
        seen[name] = path
        stack += _with_parents(name)[:-1] + sorted(_imported_names(path, name))
    return tuple(sorted(set(seen.values())))


@functools.cache
def code_digest(*modules: str, exclude: tuple[str, ...] = ()) -> str:
    """SHA-256 (16 hex digits) over the path and bytes of every file in the modules' import closure, but for
    the modules (and packages) named in `exclude`: code that stores or ships a result without shaping it."""
    skip = [module_path(name).parent if module_path(name).name == "__init__.py" else module_path(name)
            for name in exclude]
    digest = hashlib.sha256()
    for path in import_closure(*modules):
        if any(path == s or s in path.parents for s in skip if s.is_dir()) or path in skip:
            continue
        digest.update(path.relative_to(ROOT).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _jsonable(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__class__": type(value).__name__, **dataclasses.asdict(value)}
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return sorted(value, key=repr)
    raise TypeError(f"cannot put {type(value).__name__} {value!r} into a settings digest")


def constants_of(*modules: str) -> dict[str, Any]:
    """The module-level constants (UPPER_CASE names holding data) of the given modules, by qualified name.

    Read at call time, so a key built from them follows a constant changed at run time, as a test does.
    """
    out: dict[str, Any] = {}
    for name in modules:
        for attr, value in sorted(vars(importlib.import_module(name)).items()):
            if attr.isupper() and not callable(value) and not inspect.ismodule(value):
                try:
                    json.dumps(value, default=_jsonable)
                except TypeError:
                    continue  # a handle (a pybullet quaternion helper, a compiled object): not a setting
                out[f"{name}.{attr}"] = value
    return out


def settings_digest(settings: Any) -> str:
    """SHA-256 (16 hex digits) of a JSON-able structure of settings (dataclasses and tuples allowed)."""
    text = json.dumps(settings, sort_keys=True, default=_jsonable)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
