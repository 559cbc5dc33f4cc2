"""What code a result came from: a module's import closure inside the project, and digests of its code.

- `result_digest("pkg.module:entry", ...)`: the definitions reachable from an evaluator's entry points and the
  values of the constants among them. Evaluation-cache keys and the committed ground-truth tables use it, so
  moving code, editing imports, docstrings or error messages keeps hours of measurement valid.
- `code_digest(*modules)`: every definition in the modules' import closure (checkpoint and model keys).
Both hash normalised syntax trees (`_ResultCode`), not files: paths, comments and layout do not count. The DVC
deps test uses `import_closure` to check that each stage lists every project module it imports.
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import hashlib
import importlib
import json
from pathlib import Path
from typing import Any

from robocompose.io.dispatch import dispatch_tag

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


class _ResultCode(ast.NodeTransformer):
    """Keeps what can change a result: drops docstrings, imports (where a name comes from is not what it does),
    type annotations of arguments and returns, and raise statements (error types and messages)."""

    def visit_Import(self, node: ast.AST) -> None:
        return None

    visit_ImportFrom = visit_Import

    def visit_Raise(self, node: ast.Raise) -> ast.Pass:
        return ast.Pass()

    def visit_arg(self, node: ast.arg) -> ast.arg:
        node.annotation = None
        return node

    def generic_visit(self, node: ast.AST) -> ast.AST:
        body = getattr(node, "body", None)
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            node.returns = None
        return super().generic_visit(node)


@dataclasses.dataclass(frozen=True)
class _Definition:
    """One top-level definition of a file: its normalised code, the names its code refers to, and, for an
    UPPER_CASE assignment, the constant it defines (module, name) whose run-time value also counts."""

    code: str
    refers_to: frozenset[str]
    constant: tuple[str, str] | None = None


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _target_names(node: ast.AST) -> list[str]:
    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
    return [n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)]


@functools.cache
def definitions(path: Path) -> tuple[dict[str, tuple[_Definition, ...]], dict[str, str]]:
    """The top-level functions, classes and assignments of one file by name (a class also under the names of its
    methods, so `obj.method` reaches it), and the file's import aliases (`as` name -> imported name)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    module = _module_name(path)
    table: dict[str, list[_Definition]] = {}
    aliases: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            aliases.update({a.asname: a.name.rpartition(".")[2] for a in node.names if a.asname})
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names = [node.name]
            if isinstance(node, ast.ClassDef):
                names += [n.name for n in node.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            names = [n for n in _target_names(node) if n != "__all__"]
        else:
            continue  # imports, the docstring, `if __name__ == ...` blocks: not a definition
        normalised = _ResultCode().visit(node)
        refers_to = frozenset(n.id if isinstance(n, ast.Name) else n.attr for n in ast.walk(normalised)
                              if isinstance(n, (ast.Name, ast.Attribute)))
        code = ast.dump(normalised)
        for name in names:
            constant = (module, name) if name.isupper() and isinstance(node, (ast.Assign, ast.AnnAssign)) else None
            table.setdefault(name, []).append(_Definition(code, refers_to, constant))
    return {k: tuple(v) for k, v in table.items()}, aliases


def _closure_files(modules: tuple[str, ...], exclude: tuple[str, ...]) -> list[Path]:
    skip = [module_path(name) for name in exclude]
    skip = [p.parent if p.name == "__init__.py" else p for p in skip if p is not None]
    return [path for path in import_closure(*modules)
            if not any(path == s or (s.is_dir() and s in path.parents) for s in skip)]


def _digest(parts: set[str]) -> str:
    return hashlib.sha256("\0".join(sorted(parts)).encode()).hexdigest()[:16]


@functools.cache
def code_digest(*modules: str, exclude: tuple[str, ...] = ()) -> str:
    """SHA-256 (16 hex digits) over the definitions (functions, classes, constants; normalised by `_ResultCode`)
    of every file in the modules' import closure, but for the modules (and packages) named in `exclude`: code that
    stores or ships a result without shaping it. Paths, imports, docstrings, comments and layout do not count, so
    moving a definition to another module keeps the digest."""
    return _digest({d.code for path in _closure_files(modules, exclude)
                    for defs in definitions(path)[0].values() for d in defs})


# Storage, fan-out and parameter loading: they keep, ship and validate results and settings but do not shape a
# result (settings enter keys by value), so a result digest never follows a name into them.
INFRASTRUCTURE = ("robocompose.io", "robocompose.fanout", "robocompose.params")


@functools.cache
def _reached(entries: tuple[str, ...]) -> tuple[frozenset[str], tuple[tuple[str, str], ...]]:
    """The normalised code of every definition the entry points reach, and the constants among them."""
    modules = tuple(sorted({entry.partition(":")[0] for entry in entries}))
    table: dict[str, list[_Definition]] = {}
    aliases: dict[str, str] = {}
    for path in _closure_files(modules, INFRASTRUCTURE):
        defs, file_aliases = definitions(path)
        aliases.update(file_aliases)
        for name, found in defs.items():
            table.setdefault(name, []).extend(found)
    todo = [entry.partition(":")[2] for entry in entries]
    missing = [name for name in todo if name not in table]
    if missing:
        raise ValueError(f"result_digest: no definition named {missing[0]!r} in {modules}")
    seen: set[str] = set()
    reached: list[_Definition] = []
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        reached += table.get(name, ())
        todo += [n for d in table.get(name, ()) for n in d.refers_to - seen]
        if name in aliases:  # `import x as y`: y reaches x
            todo.append(aliases[name])
    return frozenset(d.code for d in reached), tuple(sorted({d.constant for d in reached if d.constant}))


def result_digest(*entries: str) -> str:
    """SHA-256 (16 hex digits) of the code a result comes from: the definitions reachable by name from the entry
    points (`"package.module:function"`) in the entry modules' import closure less `INFRASTRUCTURE`, and the
    current values of the module constants among them (read at call time: a constant patched at run time counts).

    A name reaches every top-level definition of that name in the closure, an attribute `x.m` every class with a
    method `m` (an over-approximation, so nothing that runs is missed). Moving code between modules, editing
    imports, docstrings, comments, error messages, annotations or code no entry reaches keeps the digest."""
    codes, constants = _reached(tuple(entries))
    values = set()
    for module, name in constants:
        try:
            value = getattr(importlib.import_module(module), name)
            values.add(f"{name}={json.dumps(value, default=_jsonable, sort_keys=True)}")
        except TypeError:
            continue  # a handle (a pybullet quaternion helper, a compiled object): its code counts, not its value
    return _digest(codes | values)


def _jsonable(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__class__": type(value).__name__, **dataclasses.asdict(value)}
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return sorted(value, key=repr)
    raise TypeError(f"cannot put {type(value).__name__} {value!r} into a settings digest")


def settings_digest(settings: Any) -> str:
    """SHA-256 (16 hex digits) of a JSON-able structure of settings (dataclasses and tuples allowed).

    Outside the pinned dispatch the digest covers the dispatch too (`dispatch_tag`): results computed natively
    round differently and must not be served from, or into, a cache of pinned results. Pinned digests are the
    settings' alone, so every committed key stays as it was.
    """
    tag = dispatch_tag()
    text = json.dumps({"settings": settings, "dispatch": tag} if tag else settings, sort_keys=True, default=_jsonable)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
