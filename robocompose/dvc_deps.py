"""dvc.yaml's code deps, derived: each stage lists its script, then the exact cover of the script's import closure.

    python -m robocompose.dvc_deps           # rewrite dvc.yaml's code deps (`make deps`)
    python -m robocompose.dvc_deps --check   # exit 1 naming each stage whose code deps are not the derived ones

A stage's code deps are its script and the shortest list of folders and files of the package that covers exactly
the modules importing the script runs (`import_closure`: transitive, function-level imports included; a folder
stands for every `.py` file in it). Its other deps (data files) keep their place after the code deps. Only the
`deps:` lists change; comments, the order of stages and every other line stay as they are.

This file sits outside every folder a stage lists whole and no stage imports it, so editing it reruns nothing.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import yaml

from robocompose.io import provenance
from robocompose.io.provenance import PACKAGE, import_closure

DVC_YAML = "dvc.yaml"
_STAGE = re.compile(r"^  (?P<name>[^\s#:][^:]*):")  # a stage's name, under the top-level `stages:`
_DEPS = re.compile(r"^    deps:\s*(#.*)?$")
_ITEM = re.compile(r"^      - ")


def project_sources(folder: Path, root: Path) -> set[str]:
    """The `.py` files under `folder`, relative to `root`."""
    return {p.relative_to(root).as_posix() for p in folder.rglob("*.py") if "__pycache__" not in p.parts}


def exact_cover(files: set[str], root: Path, folder: str = PACKAGE) -> list[str]:
    """The shortest list of folders and files under `folder` that covers exactly `files` (of its .py files)."""
    if project_sources(root / folder, root) <= files:
        return [folder]
    cover = []
    for child in sorted((root / folder).iterdir()):
        rel = child.relative_to(root).as_posix()
        if child.is_dir() and child.name != "__pycache__" and project_sources(child, root) & files:
            cover += exact_cover(files, root, rel)
        elif child.suffix == ".py" and rel in files:
            cover.append(rel)
    return cover


def stage_script(name: str, cmd: str) -> str:
    """The one Python script a stage's command runs."""
    scripts = [word for word in cmd.split() if word.endswith(".py")]
    if len(scripts) != 1:
        raise ValueError(f"{DVC_YAML}: stage {name}: cmd {cmd!r} should run one python script")
    return scripts[0]


def code_deps(script: str) -> list[str]:
    """The script, then the exact cover of the project modules importing it runs."""
    root = provenance.ROOT
    closure = {p.relative_to(root).as_posix() for p in import_closure(root / script)}
    return [script, *exact_cover(closure, root)]


def _is_code(dep: str, script: str) -> bool:
    return dep == script or dep == PACKAGE or dep.startswith(PACKAGE + "/")


def derived_deps(name: str, stage: dict) -> list[str]:
    """A stage's deps with its code deps derived: the script and its closure's cover, then its other deps."""
    script = stage_script(name, stage["cmd"])
    return code_deps(script) + [dep for dep in stage.get("deps", []) if not _is_code(dep, script)]


def rewrite(text: str) -> str:
    """dvc.yaml's text with every stage's `deps:` list replaced by the derived one, every other line kept."""
    document = yaml.safe_load(text)
    wanted = {name: derived_deps(name, stage) for name, stage in document["stages"].items()}
    lines, out, stage, top = text.splitlines(keepends=True), [], None, None
    index = 0
    while index < len(lines):
        line = lines[index]
        index += 1
        out.append(line)
        if line[:1].strip() and not line.startswith("#"):
            top = line.split(":")[0]
        elif top == "stages" and (match := _STAGE.match(line)):
            stage = match["name"]
        elif top == "stages" and stage in wanted and _DEPS.match(line):
            while index < len(lines) and _ITEM.match(lines[index]):
                index += 1
            out += [f"      - {dep}\n" for dep in wanted[stage]]
    result = "".join(out)
    for name, stage_def in document["stages"].items():
        stage_def["deps"] = wanted[name]
    if yaml.safe_load(result) != document:
        raise ValueError(f"{DVC_YAML}: a stage's deps are not a block list of one path per line at six spaces "
                         "(`    deps:` then `      - path`): rewrite them so, then run `make deps` again")
    return result


def stale_stages(text: str) -> list[str]:
    """One line per stage whose deps differ from the derived ones: what to add and what to drop."""
    lines = []
    for name, stage in yaml.safe_load(text)["stages"].items():
        listed, wanted = stage.get("deps", []), derived_deps(name, stage)
        if listed != wanted:
            added, dropped = [d for d in wanted if d not in listed], [d for d in listed if d not in wanted]
            lines.append(f"stage {name}: add {added}, drop {dropped}" if added or dropped
                         else f"stage {name}: deps out of order")
    return lines


def main(argv: list[str]) -> int:
    """Rewrite dvc.yaml at the project's root (`--check`: only say which stages are stale; 1 if any)."""
    path = provenance.ROOT / DVC_YAML
    text = path.read_text()
    stale = stale_stages(text)
    if argv == ["--check"]:
        print("\n".join([*stale, "run `make deps`"]) if stale else f"{DVC_YAML}: code deps up to date")
        return 1 if stale else 0
    if argv:
        raise SystemExit("usage: python -m robocompose.dvc_deps [--check]")
    new = rewrite(text)
    if new != text:
        path.write_text(new)
    print(f"{DVC_YAML}: {'rewrote' if new != text else 'up to date'}: {len(stale)} stage(s) changed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
