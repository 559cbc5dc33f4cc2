import pyarrow as pa
import pytest

from robocompose.io import LIST_LENGTHS, SCHEMAS, get_schema


def test_designs_schema_contract() -> None:
    schema = SCHEMAS["designs"]
    assert schema.names == ["design_id", "rules", "parents", "tokens", "n_links", "n_joints", "contacts"]
    assert schema.field("design_id").type == pa.string() and not schema.field("design_id").nullable
    assert schema.field("rules").type == pa.list_(pa.int16())
    assert schema.field("parents").type == pa.list_(pa.int32())
    assert schema.field("tokens").type == pa.list_(pa.int16())
    assert schema.field("n_links").type == pa.int16()
    assert schema.field("contacts").type == pa.list_(pa.float32())
    assert LIST_LENGTHS[("designs", "contacts")] == 16


def test_eval_cache_reward_is_the_only_nullable_column() -> None:
    schema = SCHEMAS["eval_cache"]
    assert [f.name for f in schema if f.nullable] == ["reward"]
    assert schema.field("seed").type == pa.int64() and schema.field("reward").type == pa.float64()


def test_list_lengths_refer_to_declared_list_columns() -> None:
    for (table, column), length in LIST_LENGTHS.items():
        assert pa.types.is_list(SCHEMAS[table].field(column).type)
        assert length > 0


def test_unknown_schema_names_the_declared_ones() -> None:
    with pytest.raises(KeyError, match="designs"):
        get_schema("desings")
