"""Shared fixtures: the two reference designs of the RoboGrammar/GLSO papers; a Foxglove validator of MCAP logs."""

import json
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

from robocompose.evaluation.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree
from robocompose.io.mcap_log import SCALARS, SCALARS_SCHEMA, foxglove_schema_bytes

FLAT_REFERENCE = REFERENCE_DESIGNS["robogrammar_flat"]
RIDGED_REFERENCE = REFERENCE_DESIGNS["robogrammar_ridged"]


@pytest.fixture(params=[FLAT_REFERENCE, RIDGED_REFERENCE], ids=["flat", "ridged"])
def reference_rules(request) -> str:
    return request.param


def reversed_siblings(tree: DesignTree) -> DesignTree:
    """The same design with every node's children in reverse order (as a decoder may order them)."""
    order, parents, queue = [], [], [(0, -1)]
    while queue:
        node, parent = queue.pop(0)
        order.append(node)
        parents.append(parent)
        queue.extend((j, len(order) - 1) for j in reversed(tree.children(node)))
    return DesignTree(tuple(parents), tuple(tree.tokens[i] for i in order))


@pytest.fixture
def reorder():
    return reversed_siblings


def official_schema(name: str) -> dict:
    """The published schema of message `name`: Foxglove's vendored files, or the project's own Scalars schema."""
    return SCALARS_SCHEMA if name == SCALARS else json.loads(foxglove_schema_bytes(name))


def assert_valid_foxglove_log(path: Path) -> int:
    """Every message of the MCAP log at `path` validates against the official schema of its name (the draft the
    schema declares; Draft 2020-12 if none), and each channel embeds exactly that schema. Returns the count."""
    checked = 0
    with Path(path).open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema is not None and schema.encoding == "jsonschema" and channel.message_encoding == "json"
            official = official_schema(schema.name)
            assert json.loads(schema.data) == official, f"{channel.topic}: embedded schema is not {schema.name}'s"
            validator = jsonschema.validators.validator_for(official, default=jsonschema.Draft202012Validator)
            validator.check_schema(official)
            error = jsonschema.exceptions.best_match(validator(official).iter_errors(json.loads(message.data)))
            assert error is None, f"{channel.topic} at {message.log_time} ns: {error.json_path}: {error.message}"
            checked += 1
    assert checked > 0
    return checked


@pytest.fixture
def valid_foxglove_log():
    """assert_valid_foxglove_log(path): every message matches the official schema of its name."""
    return assert_valid_foxglove_log
