import numpy as np
import pytest

from robocompose.io.errors import InputError
from robocompose.teams.species import (
    SPEED_SCALE,
    allocation_to_counts,
    deployment_cost,
    parse_allocation,
    step_lengths,
)


def test_step_lengths_follow_table_5_3_and_the_scaling():
    lengths = step_lengths()
    assert lengths.shape == (3, 4)
    assert lengths[0, 0] == 0.0 and lengths[2, 1] == 0.0 and lengths[2, 2] == 0.0  # ground/aquatic blocked
    assert lengths[1, 0] == pytest.approx(50 * SPEED_SCALE)


def test_counts_round_fractions_and_never_exceed_the_bank():
    fractions = np.array([[0.5, 0.0, 0.26], [0.5, 0.1, 0.26], [0.0, 0.0, 0.26], [0.0, 0.0, 0.26]])
    counts = allocation_to_counts(fractions, robots_per_species=20)
    assert counts[:, 0].tolist() == [10, 10, 0, 0]
    assert counts[:, 1].tolist() == [0, 2, 0, 0]
    # 4 x 0.26 sums above 1: scaled to 0.25 each -> 5 robots each, 20 in all
    assert counts[:, 2].tolist() == [5, 5, 5, 5]
    many = allocation_to_counts(np.random.default_rng(0).random((200, 7, 3)), robots_per_species=20)
    assert (many.sum(axis=-2) <= 20).all() and (many >= 0).all()


def test_rounding_overflow_is_taken_from_the_most_rounded_up_entries():
    counts = allocation_to_counts(np.full((4, 1), 0.25), robots_per_species=6)  # 1.5 each rounds to 2
    assert counts.sum() == 6 and counts.max() - counts.min() <= 1


def test_deployment_cost_counts_robots():
    assert deployment_cost(np.array([[[1, 2, 3], [0, 0, 4]]])).tolist() == [10]


def test_bad_allocations_are_rejected_with_the_expected_form():
    with pytest.raises(ValueError, match="non-negative"):
        allocation_to_counts(np.array([[-0.1, 0.2, 0.0]]), 20)
    with pytest.raises(InputError, match="f_ground,f_aerial,f_aquatic"):
        parse_allocation("0.1,0.2;0.3,0.4,0.5")
    assert parse_allocation("0.1,0.2,0.3;0,0,0.7").shape == (2, 3)
    with pytest.raises(InputError, match="the aquatic fractions sum to 1.3"):
        parse_allocation("0.1,0.2,0.3;0,0,1")
