import json
import os
from pathlib import Path

import pytest

from robocompose.io import ArtifactError, atomic_path, atomic_write_json, atomic_write_text, read_json


def test_atomic_path_yields_hidden_sibling_with_same_suffix_and_renames(tmp_path: Path) -> None:
    target = tmp_path / "new" / "dir" / "out.parquet"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent  # parents were created, rename stays on one filesystem
        assert tmp.name.startswith(".") and tmp.suffix == ".parquet"
        tmp.write_bytes(b"payload")
        assert not target.exists()  # nothing visible before the block ends
    assert target.read_bytes() == b"payload"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.parquet"]


def test_exception_leaves_neither_target_nor_temp(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError, match="crash mid-write"):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("crash mid-write")
    assert list(tmp_path.iterdir()) == []


def test_exception_keeps_existing_target_intact(tmp_path: Path) -> None:
    target = atomic_write_text(tmp_path / "out.txt", "old complete content\n")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_text("new but half")
            raise KeyboardInterrupt
    assert target.read_text() == "old complete content\n"
    assert list(tmp_path.iterdir()) == [target]


def test_success_replaces_existing_target(tmp_path: Path) -> None:
    target = atomic_write_text(tmp_path / "out.txt", "old")
    atomic_write_text(target, "new")
    assert target.read_text() == "new"


def test_atomic_write_json_is_sorted_indented_with_trailing_newline(tmp_path: Path) -> None:
    path = atomic_write_json(tmp_path / "m.json", {"b": 1, "a": [1, 2]})
    text = path.read_text()
    assert text == '{\n  "a": [\n    1,\n    2\n  ],\n  "b": 1\n}\n'
    assert json.loads(text) == {"a": [1, 2], "b": 1}


def test_read_json_round_trips_and_names_a_bad_file(tmp_path: Path) -> None:
    assert read_json(atomic_write_json(tmp_path / "m.json", {"a": [1, 2]})) == {"a": [1, 2]}
    (tmp_path / "cut.json").write_text('{"a": [1,')
    with pytest.raises(ArtifactError, match=r"cut\.json: not valid JSON"):
        read_json(tmp_path / "cut.json")
    with pytest.raises(ArtifactError, match=r"none\.json: file not found"):
        read_json(tmp_path / "none.json")


def test_a_killed_writers_temporary_is_removed_by_the_next_write_and_a_live_writers_kept(tmp_path: Path) -> None:
    """SIGKILL runs no cleanup: the temporary file of a writer killed mid-write stays until the next write of the
    same file removes it (a resumed stage must leave what an uninterrupted one leaves); a running writer's stays."""
    import subprocess
    import sys

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    dead_pid = int(dead.stdout)
    killed = tmp_path / f".out.{dead_pid}.0123abcd.tmp.parquet"
    live = tmp_path / f".out.{os.getpid()}.89abcdef.tmp.parquet"
    other = tmp_path / f".other.{dead_pid}.0123abcd.tmp.parquet"  # another file's: not this write's business
    for path in (killed, live, other):
        path.write_bytes(b"half")
    with atomic_path(tmp_path / "out.parquet") as tmp:
        tmp.write_bytes(b"whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, other.name, "out.parquet"])
