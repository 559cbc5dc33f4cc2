"""The input-error contract, property-based: every text parser and params section either parses or raises the
project's InputError, never anything else; valid inputs parse to what they say.

Deterministic (derandomize, no example database) and small (a few hundred examples per property), so CI is stable.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocompose.dataset.enumerate import EnumerateConfig
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.evaluation.references import ReferencesConfig
from robocompose.grammar.derivation import derive, parse_rules, random_derivation
from robocompose.io.errors import ArtifactError, InputError, error_line
from robocompose.latent.cli import parse_latent
from robocompose.latent.model import VAEConfig
from robocompose.latent.train import TrainConfig
from robocompose.modular.params import ModularParams
from robocompose.modular.robot import MODULE_LETTERS, N_PORTS, parse_design
from robocompose.params import build_config
from robocompose.teams.chips import ChipsConfig
from robocompose.teams.decompose import DecomposeConfig
from robocompose.teams.ergodic import CoverageConfig
from robocompose.teams.params import ExperimentsConfig
from robocompose.teams.species import SPECIES, parse_allocation

CHECK = settings(max_examples=200, deadline=None, derandomize=True, database=None)
LIGHT = settings(max_examples=60, deadline=None, derandomize=True, database=None)

# Text close to what the parsers expect (digits, separators, signs, number words) plus anything at all.
NUMBERISH = st.text(alphabet="0123456789,;.-+e naifNIF", max_size=40)
ANY_TEXT = st.one_of(NUMBERISH, st.text(max_size=40))
# Values a YAML file can hold.
YAML_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(), st.text(max_size=8)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=8,
)


def parses_or_input_error(parse, *args):
    """parse(*args), or None if it raised InputError (anything else propagates and fails the test)."""
    try:
        return parse(*args)
    except InputError as err:
        assert "\n" not in error_line("x", err)
        return None


def test_artifact_errors_are_input_errors():
    assert issubclass(ArtifactError, InputError) and issubclass(InputError, ValueError)


@CHECK
@given(ANY_TEXT)
def test_rule_sequences(text):
    derivation = parses_or_input_error(lambda t: derive(parse_rules(t)), text)
    assert derivation is None or derivation.graph.complete


@LIGHT
@given(st.integers(0, 2**32 - 1))
def test_valid_rule_sequences_parse_to_their_design(seed):
    derivation = random_derivation(np.random.default_rng(seed))
    if derivation is not None:
        text = ",".join(map(str, derivation.rules))
        assert derive(parse_rules(text)).tree.design_id == derivation.tree.design_id


@CHECK
@given(ANY_TEXT)
def test_port_strings(text):
    design = parses_or_input_error(parse_design, text)
    assert design is None or (len(design) == N_PORTS and set(design) <= set(MODULE_LETTERS))


@CHECK
@given(st.text(alphabet=MODULE_LETTERS + MODULE_LETTERS.upper(), min_size=N_PORTS, max_size=N_PORTS))
def test_valid_port_strings_parse(text):
    assert parse_design(text) == text.lower()


@CHECK
@given(ANY_TEXT)
def test_allocations(text):
    fractions = parses_or_input_error(parse_allocation, text)
    if fractions is not None:
        assert fractions.shape[1] == len(SPECIES) and np.isfinite(fractions).all()
        assert (fractions >= 0).all() and (fractions.sum(axis=0) <= 1 + 1e-9).all()


@CHECK
@given(st.integers(1, 6).flatmap(lambda k: st.lists(
    st.lists(st.floats(0, 1), min_size=len(SPECIES), max_size=len(SPECIES)), min_size=k, max_size=k)))
def test_valid_allocations_parse_and_are_never_rescaled(rows):
    matrix = np.array(rows)
    matrix = matrix / np.maximum(matrix.sum(axis=0), 1.0)  # each species' shares sum to at most 1
    text = ";".join(",".join(repr(float(v)) for v in row) for row in matrix)
    if (matrix.sum(axis=0) <= 1 + 1e-9).all():
        np.testing.assert_array_equal(parse_allocation(text), matrix)
    over = matrix.copy()
    over[:, 0] += (1.01 - over[:, 0].sum()) / len(over)  # the ground shares now sum to 1.01: more than all robots
    with pytest.raises(InputError, match="ground"):
        parse_allocation(";".join(",".join(repr(float(v)) for v in row) for row in over))


@CHECK
@given(ANY_TEXT, st.integers(1, 6))
def test_latent_vectors(text, dims):
    z = parses_or_input_error(parse_latent, text, dims)
    assert z is None or (len(z) == dims and all(math.isfinite(v) for v in z))


@CHECK
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=6))
def test_valid_latent_vectors_parse(z):
    assert parse_latent(",".join(map(repr, z)), len(z)) == z


SECTIONS = [EnumerateConfig, EvaluationConfig, ReferencesConfig, VAEConfig, TrainConfig, ChipsConfig,
            DecomposeConfig, CoverageConfig, ExperimentsConfig]


@pytest.mark.parametrize("cls", SECTIONS, ids=lambda cls: cls.__name__)
def test_params_sections(cls):
    names = [f for f in cls.__dataclass_fields__]

    @LIGHT
    @given(st.one_of(YAML_VALUES, st.dictionaries(st.sampled_from(names), YAML_VALUES, max_size=3)))
    def check(values):
        parses_or_input_error(build_config, cls, values, "params.yaml: section")

    check()


@LIGHT
@given(st.dictionaries(st.sampled_from(["eval", "fitness", "experiments", "workers"]), YAML_VALUES, max_size=3))
def test_modular_params_section(values):
    parses_or_input_error(build_config, ModularParams, values, "params.yaml: modular")


@pytest.mark.parametrize("cls", [c for c in SECTIONS if c is not EnumerateConfig], ids=lambda cls: cls.__name__)
def test_default_sections_parse(cls):
    assert build_config(cls, {}, "params.yaml: section") == cls()


@pytest.mark.parametrize(("value", "low", "high", "bounds", "message"), [
    (float("nan"), 0.0, None, "()", "f: expected a finite number > 0, found nan"),
    (float("inf"), 0.0, None, "[]", "f: expected a finite number >= 0, found inf"),
    (1.5, 0.0, 1.0, "()", "f: expected a finite number in (0, 1), found 1.5"),
    (0.0, 0.0, 1.0, "(]", "f: expected a finite number in (0, 1], found 0.0"),
    (True, None, None, "[]", "f: expected a finite number, found True"),
])
def test_check_number_refuses_what_has_no_right_answer(value, low, high, bounds, message):
    from robocompose.io.errors import check_number

    with pytest.raises(InputError) as error:
        check_number(value, "f", low, high, bounds)
    assert str(error.value) == message


def test_check_number_passes_the_ends_it_includes():
    from robocompose.io.errors import check_number

    for value in (0, 0.5, 1):
        check_number(value, "f", 0.0, 1.0, "[]")
