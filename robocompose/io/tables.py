"""Parquet tables checked against the declared schemas: deterministic writes, validating reads."""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from robocompose.io.atomic import atomic_path
from robocompose.io.errors import ArtifactError
from robocompose.io.schemas import LIST_LENGTHS, get_schema

# Fixed writer settings: the same table always gives the same bytes (the file records only the
# pyarrow version, no timestamps). Page checksums let the reader detect corrupted pages.
_WRITE_OPTIONS = {"compression": "zstd", "compression_level": 3, "write_page_checksum": True}

_LIST_TYPES = (pa.types.is_list, pa.types.is_large_list, pa.types.is_fixed_size_list)


def _is_list(t: pa.DataType) -> bool:
    return any(check(t) for check in _LIST_TYPES)


def _convertible(found: pa.DataType, expected: pa.DataType) -> bool:
    """Whether a write may cast `found` to `expected`: within a kind (numbers, strings, lists).

    Arrow would also parse strings into numbers; a string column where a number is declared is a
    bug upstream, so it is refused rather than parsed.
    """
    if pa.types.is_null(found):  # all-null or empty columns: the null/length checks decide
        return True
    if _is_list(expected):
        return _is_list(found) and _convertible(found.value_type, expected.value_type)
    if pa.types.is_integer(expected) or pa.types.is_floating(expected):
        # Floats are allowed for integer columns because pandas stores ints with gaps as float;
        # the safe cast still refuses fractional values.
        return pa.types.is_integer(found) or pa.types.is_floating(found)
    if pa.types.is_string(expected) or pa.types.is_large_string(expected):
        return pa.types.is_string(found) or pa.types.is_large_string(found)
    return found.equals(expected)


def _same_type(found: pa.DataType, expected: pa.DataType) -> bool:
    """Exact type match, except the list item field name (parquet writers differ: item/element)."""
    if pa.types.is_list(expected):
        return pa.types.is_list(found) and _same_type(found.value_type, expected.value_type)
    return found.equals(expected)


def _check_columns(columns: list[str], schema: str, source: Path) -> None:
    declared = get_schema(schema).names
    missing = [c for c in declared if c not in columns]
    if missing:
        raise ArtifactError(
            f"{source}: column {missing[0]!r} missing (table {schema!r} expects columns {declared}, "
            f"found {columns})"
        )
    extra = [c for c in columns if c not in declared]
    if extra:
        raise ArtifactError(
            f"{source}: unexpected column {extra[0]!r} (table {schema!r} declares only {declared})"
        )


def _check_values(table: pa.Table, schema: str, source: Path) -> None:
    """Not-null columns hold no nulls; fixed-length list columns hold lists of exactly that length."""
    for field in get_schema(schema):
        column = table.column(field.name)
        if not field.nullable and column.null_count:
            first = pc.index(pc.is_null(column), True).as_py()
            raise ArtifactError(
                f"{source}: column {field.name!r}: expected no nulls, found {column.null_count} "
                f"(first at row {first})"
            )
        length = LIST_LENGTHS.get((schema, field.name))
        if length is not None:
            wrong = pc.fill_null(pc.not_equal(pc.list_value_length(column), length), False)
            if pc.any(wrong).as_py():
                row = pc.index(wrong, True).as_py()
                found = len(column[row].as_py())
                raise ArtifactError(
                    f"{source}: column {field.name!r}: expected lists of exactly {length} values, "
                    f"found {found} at row {row}"
                )


def _to_declared(data: pd.DataFrame | pa.Table, schema: str, source: Path) -> pa.Table:
    """Convert `data` to the declared schema, naming the column that does not fit."""
    declared = get_schema(schema)
    is_frame = isinstance(data, pd.DataFrame)
    _check_columns([str(c) for c in data.columns] if is_frame else data.column_names, schema, source)
    columns = []
    for field in declared:
        try:
            values = pa.array(data[field.name], from_pandas=True) if is_frame else data.column(field.name)
        except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
            raise ArtifactError(
                f"{source}: column {field.name!r}: expected {field.type}, found values arrow cannot "
                f"convert ({exc})"
            ) from exc
        if not _convertible(values.type, field.type):
            raise ArtifactError(
                f"{source}: column {field.name!r}: expected {field.type}, found {values.type}"
            )
        try:
            columns.append(values.cast(field.type))
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError) as exc:
            raise ArtifactError(
                f"{source}: column {field.name!r}: expected {field.type}, found {values.type} values "
                f"that do not fit ({exc})"
            ) from exc
    table = pa.Table.from_arrays(columns, schema=declared)
    _check_values(table, schema, source)
    return table


def write_table(data: pd.DataFrame | pa.Table, path: str | os.PathLike[str], schema: str) -> Path:
    """Write `data` as the declared table `schema` to `path` (parquet, atomic, byte-deterministic).

    Columns are converted to the declared types (and order); the pandas index is not stored.
    Raises ArtifactError naming the column that is missing, unexpected, of the wrong type, null
    where not allowed, or a list of the wrong length.
    """
    target = Path(path)
    table = _to_declared(data, schema, target)
    with atomic_path(target) as tmp:
        pq.write_table(table, tmp, **_WRITE_OPTIONS)
    return target


def read_table(path: str | os.PathLike[str], schema: str) -> pd.DataFrame:
    """Read the parquet table at `path` and check it against the declared table `schema`.

    Raises ArtifactError naming the file (and column) if the file is missing, is not readable
    parquet (truncated, corrupted), or its columns, types, nulls or list lengths do not match.
    """
    source = Path(path)
    declared = get_schema(schema)
    if not source.is_file():
        raise ArtifactError(f"{source}: file not found (expected the {schema!r} parquet table)")
    try:
        table = pq.read_table(source, page_checksum_verification=True)
        columns = table.column_names  # decoded lazily: a corrupted footer fails here
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        raise ArtifactError(
            f"{source}: not a readable parquet file, expected the {schema!r} table "
            f"({type(exc).__name__}: {exc})"
        ) from exc
    _check_columns(columns, schema, source)
    for field in declared:
        found = table.schema.field(field.name).type
        if not _same_type(found, field.type):
            raise ArtifactError(f"{source}: column {field.name!r}: expected {field.type}, found {found}")
    table = table.select(declared.names)
    _check_values(table, schema, source)
    return table.to_pandas()
