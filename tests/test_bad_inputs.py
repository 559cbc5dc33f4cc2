"""The bad-input corpus: every bad flag, params field and file a user can hand in, each one line on stderr, exit 2,
before any work, nothing written or clobbered. One parametrised test runs them all.

A case runs in a fresh folder holding `params.yaml` (the default profile with the case's `change` applied, a Python
statement on `doc`) and whatever its `setup(folder)` makes; then either `robocompose ARGV` in this process or a DVC
stage's script. It must exit with `code`, print nothing on stdout and one line on stderr (`robocompose: error: ...`
or `stage NAME: error: ...`) holding every fragment, and leave every file of the folder as it was: no output
written, none clobbered. `{tmp}` in argv and fragments is the folder. Slow cases (seconds) are marked and run in
`make test-slow`.

Cases are grouped by what they guard; each group is a list below, and CASES joins them.
"""

from __future__ import annotations

import runpy
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

from robocompose.io.provenance import ROOT

STAGES = ROOT / "stages"


@dataclass(frozen=True)
class Case:
    id: str
    fragments: tuple[str, ...]  # each must appear in the error line ({tmp}: the case's folder)
    argv: tuple[str, ...] = ()  # `robocompose ARGV`, or
    stage: str = ""  # a stage script of stages/
    change: str = ""  # a statement applied to the default profile's document `doc` before params.yaml is written
    setup: Callable[[Path], None] | None = None  # makes the case's files in its folder
    code: int = 2
    slow: bool = False
    marks: tuple = field(default=())


def png(path: Path, width: int, height: int, colour: tuple[int, int, int] = (255, 255, 255)) -> None:
    from PIL import Image

    Image.new("RGB", (width, height), colour).save(path, format="PNG")


# --- files a command reads, where it writes, and the error line itself (one line, no usage block, no banner) ---
OUTPUTS_AND_LINES = [
    Case("compose teams: a 15000 x 15000 label PNG", ("chip.png: more than 144,000,000 pixels",),
         argv=("compose", "teams", "--chip", "{tmp}/chip.png"), setup=lambda tmp: png(tmp / "chip.png", 15000, 15000)),
    Case("compose modular: a pickled height map", ("--heightmap {tmp}/map.npy: not a .npy array file",),
         argv=("compose", "modular", "--heightmap", "{tmp}/map.npy"),
         setup=lambda tmp: (tmp / "map.npy").write_bytes(b"\x80\x04\x95\x00")),
]

# --- params fields and params files ---
PARAMS = [
    Case("decompose: test_fraction out of range", ("teams.decompose.test_fraction: expected a share",),
         stage="decompose", change="doc['teams']['decompose']['test_fraction'] = 1.5"),
]

# --- sizes and bounds: counts, lengths, pixels, addresses, committed records ---
BOUNDS = [
    Case("compose modular: k zero", ("argument --k: expected an integer >= 1, found 0",),
         argv=("compose", "modular", "--terrain-seed", "1", "--k", "0")),
]

CASES = OUTPUTS_AND_LINES + PARAMS + BOUNDS


def _params(change: str) -> dict:
    document = yaml.safe_load((ROOT / "profiles" / "default.yaml").read_text())
    if change:
        exec(change, {"doc": document})
    return document


def _files(folder: Path) -> dict[str, bytes | None]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() if p.is_file() else None for p in folder.rglob("*")}


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=[*c.marks, *([pytest.mark.slow] if c.slow else [])])
                                  for c in CASES])
def test_a_bad_input_is_one_line_exit_2_and_nothing_written(case, tmp_path, monkeypatch, capsys):
    folder = tmp_path / "case"
    folder.mkdir()
    (folder / "params.yaml").write_text(yaml.safe_dump(_params(case.change)))
    if case.setup is not None:
        case.setup(folder)
    before = _files(folder)
    monkeypatch.chdir(folder)
    if case.stage:
        monkeypatch.setattr(sys, "argv", [str(STAGES / f"{case.stage}.py")])
        with pytest.raises(SystemExit) as exit_:
            runpy.run_path(str(STAGES / f"{case.stage}.py"), run_name="__main__")
        code, program = exit_.value.code, f"stage {case.stage}"
    else:
        from robocompose.cli import main

        try:
            code = main([a.replace("{tmp}", str(folder)) for a in case.argv])
        except SystemExit as exit_:  # argparse
            code = exit_.code
        program = "robocompose"
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == case.code and out == "", (code, out, err)
    assert len(lines) == 1 and lines[0].startswith(f"{program}: error: "), err
    assert all(f.replace("{tmp}", str(folder)) in lines[0] for f in case.fragments), lines[0]
    assert _files(folder) == before  # nothing written, nothing clobbered
