import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from robocompose.io import ArtifactError, read_table, write_table


def designs() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "design_id": ["d0", "d1", "d2"],
            "rules": [[0, 3, 7], [0, 1], []],
            "parents": [[-1, 0, 0, 1], [-1, 0], [-1]],
            "tokens": [[1, 5, 5, 41], [1, 2], [0]],
            "n_links": [4, 2, 1],
            "n_joints": [3, 1, 0],
            "contacts": [np.linspace(0, 1, 16), np.zeros(16), np.ones(16)],
        }
    )


def eval_cache() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "design_id": ["d0", "d1"],
            "task": ["flat", "stairs"],
            "settings_hash": ["abc", "abc"],
            "seed": [0, 1],
            "reward": [1.25, None],  # crashed evaluation: no score
            "status": ["ok", "crashed"],
            "sim_steps": [1000, 12],
            "seconds": [0.5, 0.01],
        }
    )


def test_designs_round_trip(tmp_path: Path) -> None:
    path = write_table(designs(), tmp_path / "data" / "designs.parquet", "designs")
    back = read_table(path, "designs")
    assert list(back.columns) == list(designs().columns)
    assert back["n_links"].dtype == np.int16
    assert back["design_id"].tolist() == ["d0", "d1", "d2"]
    assert [list(r) for r in back["rules"]] == [[0, 3, 7], [0, 1], []]
    assert [list(p) for p in back["parents"]] == [[-1, 0, 0, 1], [-1, 0], [-1]]
    assert back["contacts"][0].dtype == np.float32
    np.testing.assert_allclose(back["contacts"][0], np.linspace(0, 1, 16), rtol=1e-6)


def test_eval_cache_round_trip_keeps_null_reward(tmp_path: Path) -> None:
    back = read_table(write_table(eval_cache(), tmp_path / "cache.parquet", "eval_cache"), "eval_cache")
    assert back["reward"][0] == 1.25 and math.isnan(back["reward"][1])
    assert back["status"].tolist() == ["ok", "crashed"]
    assert back["seed"].dtype == np.int64


def test_same_data_gives_same_bytes(tmp_path: Path) -> None:
    first = write_table(designs(), tmp_path / "a.parquet", "designs").read_bytes()
    second = write_table(designs(), tmp_path / "b.parquet", "designs").read_bytes()
    # The same rows built another way: a pandas index, shuffled column order, arrow table in 2 chunks.
    frame = designs().set_axis([10, 20, 30])[list(reversed(designs().columns))]
    parts = [pa.Table.from_pandas(part, preserve_index=False) for part in (frame.iloc[:1], frame.iloc[1:])]
    chunked = pa.concat_tables(parts)
    third = write_table(chunked, tmp_path / "c.parquet", "designs").read_bytes()
    assert first == second == third
    assert b"pandas" not in first  # no pandas index metadata


def test_different_data_gives_different_bytes(tmp_path: Path) -> None:
    changed = designs()
    changed.loc[0, "n_links"] = 5
    a = write_table(designs(), tmp_path / "a.parquet", "designs").read_bytes()
    assert write_table(changed, tmp_path / "b.parquet", "designs").read_bytes() != a


@pytest.mark.parametrize(
    ("change", "column", "expected"),
    [
        (lambda df: df.drop(columns="rules"), "rules", "missing"),
        (lambda df: df.assign(extra=1), "extra", "unexpected column"),
        (lambda df: df.assign(n_links=["4", "2", "1"]), "n_links", "expected int16, found"),
        (lambda df: df.assign(n_joints=[1.5, 1, 0]), "n_joints", "expected int16"),
        (lambda df: df.assign(n_links=[40000, 2, 1]), "n_links", "expected int16"),
        (lambda df: df.assign(design_id=["d0", None, "d2"]), "design_id", "expected no nulls, found 1"),
        (lambda df: df.assign(tokens=[[1], ["a"], [0]]), "tokens", "expected list<item: int16>"),
        (
            lambda df: df.assign(contacts=[np.zeros(16), np.zeros(15), np.zeros(16)]),
            "contacts",
            "expected lists of exactly 16 values, found 15 at row 1",
        ),
    ],
)
def test_write_errors_name_file_and_column(tmp_path: Path, change, column: str, expected: str) -> None:
    path = tmp_path / "designs.parquet"
    with pytest.raises(ArtifactError) as info:
        write_table(change(designs()), path, "designs")
    message = str(info.value)
    assert str(path) in message and repr(column) in message and expected in message
    assert not path.exists()


def test_failed_write_keeps_previous_file(tmp_path: Path) -> None:
    path = write_table(designs(), tmp_path / "designs.parquet", "designs")
    before = path.read_bytes()
    with pytest.raises(ArtifactError):
        write_table(designs().drop(columns="tokens"), path, "designs")
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["designs.parquet"]


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ArtifactError, match=r"nope\.parquet: file not found.*'designs'"):
        read_table(tmp_path / "nope.parquet", "designs")


@pytest.mark.parametrize("corrupt", ["truncated", "random", "not_parquet"])
def test_corrupted_file(tmp_path: Path, corrupt: str) -> None:
    path = write_table(designs(), tmp_path / "designs.parquet", "designs")
    data = path.read_bytes()
    bad = {
        "truncated": data[: len(data) // 2],
        "random": np.random.default_rng(0).bytes(len(data)),
        "not_parquet": b"design_id,rules\nd0,[]\n",
    }[corrupt]
    path.write_bytes(bad)
    with pytest.raises(ArtifactError, match="designs.parquet: not a readable parquet file"):
        read_table(path, "designs")


def test_flipped_bytes_never_escape_as_raw_errors_or_silent_changes(tmp_path: Path) -> None:
    good = write_table(designs(), tmp_path / "good.parquet", "designs")
    expected = read_table(good, "designs")
    data = good.read_bytes()
    path = tmp_path / "bad.parquet"
    detected = 0
    for position in range(4, len(data) - 4, 13):  # skip the magic bytes: covered above
        flipped = bytearray(data)
        flipped[position] ^= 0xFF
        path.write_bytes(bytes(flipped))
        try:
            back = read_table(path, "designs")
        except ArtifactError:
            detected += 1
            continue
        pd.testing.assert_frame_equal(back, expected)  # an unread byte (e.g. unused metadata) flipped
    assert detected > 0


def test_read_checks_declared_types(tmp_path: Path) -> None:
    # A file written without the declared schema: int32 where int16 is declared.
    path = tmp_path / "designs.parquet"
    table = pq.read_table(write_table(designs(), path, "designs"))
    pq.write_table(table.set_column(4, "n_links", pa.array([4, 2, 1], type=pa.int32())), path)
    expected = r"designs\.parquet: column 'n_links': expected int16, found int32"
    with pytest.raises(ArtifactError, match=expected):
        read_table(path, "designs")


def test_read_checks_list_lengths_and_columns(tmp_path: Path) -> None:
    path = write_table(designs(), tmp_path / "designs.parquet", "designs")
    with pytest.raises(ArtifactError, match="column 'task' missing"):
        read_table(path, "eval_cache")
    table = pq.read_table(path)
    short = table.set_column(
        6, "contacts", pa.array([[0.0] * 16, [0.0] * 16, [0.0] * 3], type=pa.list_(pa.float32()))
    )
    pq.write_table(short, path)
    expected = "'contacts': expected lists of exactly 16 values, found 3 at row 2"
    with pytest.raises(ArtifactError, match=expected):
        read_table(path, "designs")


def test_read_accepts_files_from_other_parquet_writers(tmp_path: Path) -> None:
    # Without the stored arrow schema, lists come back as list<element: ...>, which is the same type.
    path = tmp_path / "designs.parquet"
    pq.write_table(pq.read_table(write_table(designs(), path, "designs")), path, store_schema=False)
    assert pq.read_schema(path).field("rules").type.value_field.name == "element"
    assert read_table(path, "designs")["n_joints"].tolist() == [3, 1, 0]
