"""design.md's must-not-import table, held over robocompose/ by reading every import statement of every file
(module-level and inside functions alike: a function-level import runs when the function does).

- A concept imports only concepts on its own row of the table or below it (the table lists them lowest first).
  The files at the package's top sit on the floor with io/ and fanout/ (`params.py`, `stage.py`, `arguments.py`,
  `dvc_deps.py`: they import only those two), but for `cli.py`, the command line, which stands on every concept to
  register its commands.
- Each row's "must not import" holds through the whole chain: `report/` must not reach torch through
  `latent.train`, nor `search/` the grammar through another concept. Where a forbidden concept or library is
  reached through a project module, the problem names that module's import line and the chain.
- Nothing reaches up into report/: no file outside it imports it.
- Inside a world folder, its rooms (`ROOMS`): the world itself (the folder's own files) reaches neither its plug-ins
  nor its experiments, and the plug-ins do not reach the experiments; the folder's entry files (command line,
  query, params sections) stand on all three.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

from robocompose.io.provenance import PACKAGE, ROOT

# design.md, "Concepts in robocompose/, lowest first": one row per tuple.
ROWS = [("io",), ("fanout",), ("grammar",), ("sim", "tasks"), ("dataset",), ("control", "evaluation"), ("latent",),
        ("search",), ("glso",), ("eggan",), ("modular", "teams"), ("serve",), ("report",)]
# Its "must not import" column. Libraries stand for the words: physics = pybullet, learning = torch (the learning
# concepts, latent and eggan, sit above grammar, sim and tasks anyway). The rest of the column ("anything else of
# the project", "anything but io", "latent, search" for dataset, ...) is what the rows already forbid.
MUST_NOT = {
    "grammar": {"sim", "pybullet", "torch"},
    "sim": {"search", "torch"},
    "tasks": {"search", "torch"},
    "dataset": {"latent", "search"},
    "control": {"latent", "search", "dataset"},
    "evaluation": {"latent", "search", "dataset"},
    "latent": {"search", "eggan"},
    "search": {"modular", "teams", "grammar"},
    "glso": {"eggan", "modular", "teams"},
    "eggan": {"modular", "teams"},
    "modular": {"teams"},
    "teams": {"modular"},
    "report": {"sim", "eggan", "torch", "pybullet"},
}
LIBRARIES = {"torch", "pybullet"}  # third-party names the table forbids (pybullet_data etc. count as pybullet)
FLOOR_FILES = {"params", "stage", "arguments", "dvc_deps"}  # top-level files on the floor with io/
ROOF_FILES = {"cli"}  # the command line: may import every concept but report/
# A world folder's rooms, lowest first: the world itself (the folder's own files but its entry files), its plug-ins
# for search/ and eggan/, its experiments. A room imports only rooms on or below its own row.
ROOMS = {"modular": {"rooms": ("world", "plugins", "experiments"),
                     "entry": {"cli", "compose", "params", "eggan_params"}}}



def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def concept(module: str) -> str | None:
    """The table's folder of a project module; None for the package itself."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def imports(path: Path, root: Path) -> Iterator[tuple[int, tuple[str, ...]]]:
    """(line, names) for every name an import statement of the file brings in, relative imports resolved; names
    is the module it may be, most specific first (`from pkg import name`: pkg.name, which may be a module, or
    pkg)."""
    module = module_name(path, root)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, (alias.name,)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            for alias in node.names:
                yield node.lineno, (f"{base}.{alias.name}", base)


class Tree:
    """The import graph of a package's source tree (`root`/robocompose/**.py)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.files = {module_name(p, root): p for p in sorted((root / PACKAGE).rglob("*.py"))
                      if "__pycache__" not in p.parts}
        self.edges = {name: sorted(set(self._targets(path))) for name, path in self.files.items()}
        self.reach = cache(self._reach)

    def _targets(self, path: Path) -> Iterator[tuple[int, str]]:
        """(line, project module or library name) of one file's imports."""
        for line, names in imports(path, self.root):
            module = next((name for name in names if name in self.files), None)
            top = names[-1].split(".")[0]
            if module is not None:
                yield line, module
            elif top != PACKAGE and (top.startswith("pybullet") or top in LIBRARIES):
                yield line, "pybullet" if top.startswith("pybullet") else top

    def _parents(self, module: str) -> list[str]:
        """The packages whose __init__ importing `module` runs too."""
        parts = module.split(".")
        return [p for p in (".".join(parts[:i]) for i in range(2, len(parts))) if p in self.files]

    def _reach(self, module: str) -> dict[str, tuple[str, ...]]:
        """What importing `module` runs, transitively: concept or library -> the chain of modules to it."""
        found: dict[str, tuple[str, ...]] = {}
        stack, seen = [(module, (module,))], set()
        while stack:
            name, chain = stack.pop(0)
            if name in seen:
                continue
            seen.add(name)
            if name not in self.files:  # a library
                found.setdefault(name, chain)
                continue
            if concept(name):
                found.setdefault(concept(name), chain)
            stack += [(n, (*chain, n)) for n in self._parents(name) + [t for _, t in self.edges[name]]]
        return found


def row_of(name: str) -> int | None:
    return next((i for i, row in enumerate(ROWS) if name in row), None)


def problems(root: Path) -> list[tuple[str, str, str]]:
    """(file, imported module, "file:line imports module: why") for every import that breaks the table."""
    tree = Tree(root)
    found: dict[tuple[str, str], str] = {}
    for module, path in tree.files.items():
        where = path.relative_to(root).as_posix()
        home = concept(module)
        top_file = home in FLOOR_FILES | ROOF_FILES and module.count(".") == 1
        for line, target in tree.edges[module]:
            if target not in tree.files:  # a library, checked below as its own concept
                target_concept = target
            else:
                target_concept = concept(target)
            if target_concept is None or target_concept == home:
                continue
            why = None
            if target_concept == "report" or (target_concept == "serve" and home not in ROOF_FILES):
                why = f"nothing reaches up into {target_concept}/"
            elif top_file and home in ROOF_FILES:
                pass
            elif top_file:
                if target_concept not in ("io", "fanout", *FLOOR_FILES) and target in tree.files:
                    why = f"{home}.py sits on the floor with io/ and fanout/ and imports only those"
            elif home in MUST_NOT and target_concept in MUST_NOT[home]:
                why = f"{home}/ must not import {target_concept}"
            elif target in tree.files and target_concept not in FLOOR_FILES and row_of(home) is not None \
                    and (row_of(target_concept) is None or row_of(target_concept) > row_of(home)):
                why = f"{home}/ imports only concepts below it ({target_concept}/ is above)"
            if why is None and target in tree.files and home in MUST_NOT and not top_file:
                for banned in sorted(MUST_NOT[home] & set(tree.reach(target)), key=lambda b: (b in LIBRARIES, b)):
                    chain = " -> ".join(tree.reach(target)[banned])
                    why = f"{home}/ must not import {banned} (reached through {chain})"
                    break
            if why:
                found.setdefault((where, target), (line, f"{where}:{line} imports {target}: {why}"))
    ordered = sorted(found.items(), key=lambda item: (item[0][0], item[1]))  # by file, then line
    return [(where, target, text) for (where, target), (_, text) in ordered]


def test_the_code_keeps_design_md_import_table():
    found = problems(ROOT)
    assert not found, "\n".join(text for _, _, text in found)


def room(module: str) -> str | None:
    """The room of a module of a world folder in `ROOMS` ("world", a sub-package's name); None for an entry file, the
    folder's __init__ and modules of other concepts."""
    parts = module.split(".")
    if len(parts) < 3 or parts[1] not in ROOMS:
        return None
    rooms = ROOMS[parts[1]]
    if len(parts) == 3:
        return None if parts[2] in rooms["entry"] else "world"
    return parts[2] if parts[2] in rooms["rooms"] else None


def room_problems(root: Path) -> list[str]:
    """"file:line imports module: why" for every import (or chain of imports) from a room to a room above it."""
    tree = Tree(root)
    found = []
    for module, path in tree.files.items():
        home = room(module)
        if home is None:
            continue
        order = ROOMS[concept(module)]["rooms"]
        for line, target in tree.edges[module]:
            stack, seen = [(target, (target,))], set()
            while stack:  # the chain from this import to a room above `home`, if any
                name, chain = stack.pop(0)
                if name in seen or name not in tree.files or concept(name) != concept(module):
                    continue
                seen.add(name)
                if room(name) is not None and order.index(room(name)) > order.index(home):
                    via = f" (reached through {' -> '.join(chain)})" if len(chain) > 1 else ""
                    found.append(f"{path.relative_to(root).as_posix()}:{line} imports {target}: the {home} of "
                                 f"{concept(module)}/ must not import its {room(name)}{via}")
                    break
                stack += [(n, (*chain, n)) for _, n in tree.edges[name]]
    return found


def test_the_worlds_keep_their_rooms():
    found = room_problems(ROOT)
    assert not found, "\n".join(found)


def test_the_room_checker_names_the_file_line_and_chain(tmp_path):
    root = _tree(tmp_path, {**CLEAN, "modular/robot.py": "import json\n",
                            "modular/evaluate.py": "from robocompose.modular.plugins import problem\n",
                            "modular/plugins/problem.py": "def f():\n    from robocompose.modular.robot import json\n",
                            "modular/plugins/eggan_problem.py": "from robocompose.modular.experiments import runs\n",
                            "modular/experiments/runs.py": "from robocompose.modular.plugins import problem\n",
                            "modular/cli.py": "from robocompose.modular.experiments import runs\n"})
    assert room_problems(root) == [
        "robocompose/modular/evaluate.py:1 imports robocompose.modular.plugins.problem: the world of modular/ must not "
        "import its plugins",
        "robocompose/modular/plugins/eggan_problem.py:1 imports robocompose.modular.experiments.runs: the plugins of "
        "modular/ must not import its experiments"]


def test_the_report_reaches_no_simulation_no_model_code():
    """The report reads artifacts only: importing any of its modules runs no sim/ or eggan/ code, no torch or
    pybullet (its DVC stage's deps hold none of them either)."""
    tree = Tree(ROOT)
    for module in (m for m in tree.files if concept(m) == "report"):
        reached = tree.reach(module)
        assert not {"sim", "eggan", "torch", "pybullet"} & set(reached), {k: reached[k] for k in reached
                                                                          if k in {"sim", "eggan", "torch", "pybullet"}}


# --- the checker itself, on tiny synthetic trees ---

def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for relative, text in files.items():
        path = tmp_path / PACKAGE / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    for folder in [tmp_path / PACKAGE, *(p for p in (tmp_path / PACKAGE).rglob("*") if p.is_dir())]:
        (folder / "__init__.py").touch()
    return tmp_path


CLEAN = {"io/atomic.py": "import json\n", "grammar/tree.py": "from robocompose.io.atomic import json\n",
         "sim/builder.py": "import pybullet\nfrom robocompose.grammar import tree\n",
         "eggan/query.py": "import torch\n", "latent/curves.py": "import pandas\n",
         "report/build.py": "from robocompose.latent.curves import pandas\n", "serve/app.py": "import json\n"}


@pytest.mark.parametrize(("name", "text", "expected"), [
    ("report/eggan.py", "\n\ndef f():\n    from robocompose.eggan.query import torch\n",
     "robocompose/report/eggan.py:4 imports robocompose.eggan.query: report/ must not import eggan"),
    ("grammar/bad.py", "from ..sim import builder\n",
     "robocompose/grammar/bad.py:1 imports robocompose.sim.builder: grammar/ must not import sim"),
    ("io/bad.py", "import robocompose.grammar.tree\n",
     "robocompose/io/bad.py:1 imports robocompose.grammar.tree: io/ imports only concepts below it (grammar/ is "
     "above)"),
    ("search/ga.py", "from robocompose.latent import curves\n", None),  # latent/ is below search/
    ("report/latent.py", "from robocompose.latent import model\n",
     "robocompose/report/latent.py:1 imports robocompose.latent.model: report/ must not import torch (reached "
     "through robocompose.latent.model -> torch)"),
    ("latent/model.py", "import torch\n", None),
    ("grammar/learn.py", "def f():\n    import torch.nn\n",
     "robocompose/grammar/learn.py:2 imports torch: grammar/ must not import torch"),
    ("dataset/pick.py", "from robocompose.report import build\n",
     "robocompose/dataset/pick.py:1 imports robocompose.report.build: nothing reaches up into report/"),
    ("teams/page.py", "from robocompose.serve import app\n",
     "robocompose/teams/page.py:1 imports robocompose.serve.app: nothing reaches up into serve/"),
    ("cli.py", "from robocompose.serve import app\n", None),  # the command line registers `serve`
    ("params.py", "from robocompose.grammar import tree\n",
     "robocompose/params.py:1 imports robocompose.grammar.tree: params.py sits on the floor with io/ and fanout/ "
     "and imports only those"),
])
def test_the_checker_names_the_file_line_and_import(tmp_path, name, text, expected):
    files = {**CLEAN, name: text}
    if name == "report/latent.py":
        files["latent/model.py"] = "import torch\n"
    found = [message for _, _, message in problems(_tree(tmp_path, files))]
    assert found == ([expected] if expected else [])


def test_the_checker_follows_a_chain_to_a_forbidden_library(tmp_path):
    root = _tree(tmp_path, {**CLEAN, "modular/world.py": "def f():\n    import pybullet\n",
                            "modular/summary.py": "from robocompose.modular import world\n",
                            "report/modular.py": "from robocompose.modular.summary import world\n"})
    assert [m for _, _, m in problems(root)] == [
        "robocompose/report/modular.py:1 imports robocompose.modular.summary: report/ must not import pybullet "
        "(reached through robocompose.modular.summary -> robocompose.modular.world -> pybullet)"]


def test_the_clean_synthetic_tree_passes(tmp_path):
    assert problems(_tree(tmp_path, CLEAN)) == []
