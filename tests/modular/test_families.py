import numpy as np
import pytest

from robocompose.io.errors import InputError
from robocompose.modular.families import (
    FAMILIES,
    SHEET_HEIGHT,
    family_config,
    generate,
    perturb,
)
from robocompose.modular.terrain import height_map


def _front(t):
    return t.centers[:, 0] - t.half_sides[:, 0]


def _back(t):
    return t.centers[:, 0] + t.half_sides[:, 0]


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_a_family_is_a_pure_function_of_its_seed(name):
    a, b = generate(name, 11), generate(name, 11)
    others = [generate(name, s) for s in range(12, 16)]
    for field in ("centers", "half_sides", "heights"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert any(o.heights.shape != a.heights.shape or not np.array_equal(o.heights, a.heights) for o in others)
    assert height_map(a).shape == (50, 20) and a.task_id == "blocks-11"  # the Terrain's own id: never a cache key
    config = family_config(name)
    assert (_front(a) >= config.clear_x - 1e-12).all() and (_back(a) <= config.x_range[1] + 1e-12).all()
    assert (np.abs(a.centers[:, 1]) + a.half_sides[:, 1] <= config.y_range[1] + 1e-12).all()


@pytest.mark.parametrize("seed", range(6))
def test_walls_span_the_course_within_their_ranges(seed):
    config = family_config("walls")
    t = generate("walls", seed, config)
    assert len(t.heights) >= 2
    np.testing.assert_allclose(t.half_sides[:, 1], 2.0)  # full width: no way around
    assert (2 * t.half_sides[:, 0] >= 0.05).all() and (2 * t.half_sides[:, 0] <= 0.30).all()
    tallest = t.heights.max()
    assert config.height_range[0] * 0.75 <= t.heights.min() and tallest <= config.height_range[1]
    assert (t.heights >= tallest * 0.75 * 0.999).all()  # one terrain's walls are alike (spread 0.25 of H >= tallest)
    gaps = _front(t)[1:] - _back(t)[:-1]
    assert (gaps >= 0.6 - 1e-9).all() and (gaps <= 1.5 + 1e-9).all()


@pytest.mark.parametrize("seed", range(6))
def test_steps_rise_by_one_riser_per_tread(seed):
    config = family_config("steps")
    t = generate("steps", seed, config)
    riser = t.heights[0]
    assert config.riser_range[0] <= riser <= config.riser_range[1] and len(t.heights) <= config.steps
    np.testing.assert_allclose(t.heights, riser * np.arange(1, len(t.heights) + 1))
    np.testing.assert_allclose(_back(t), config.x_range[1])  # each step runs to the course's end
    treads = np.diff(_front(t))
    assert config.tread_range[0] <= treads[0] <= config.tread_range[1] and np.allclose(treads, treads[0])
    assert config.clear_x <= _front(t)[0] <= config.clear_x + config.first_range[1]


@pytest.mark.parametrize("seed", range(4))
def test_rubble_is_dense_small_and_spaced(seed):
    config = family_config("rubble")
    t = generate("rubble", seed, config)
    assert len(t.heights) > 50
    assert (t.half_sides >= 0.02).all() and (t.half_sides <= 0.08).all()
    assert (t.heights >= 0).all() and (t.heights <= config.height_range[1]).all()
    assert (t.centers[:, 0] >= config.clear_x).all()
    gaps = np.linalg.norm(t.centers[:, None] - t.centers[None], axis=-1) + np.eye(len(t.centers)) * 99
    assert gaps.min() >= config.spacing_range[0]


@pytest.mark.parametrize("seed", range(6))
def test_ice_is_thin_slippery_sheets_and_mixed_stays_in_its_heights(seed):
    ice = generate("ice", seed)
    assert (ice.heights == SHEET_HEIGHT).all() and ice.config.friction == 0.1 and ice.config.ground_friction == 0.8
    assert (np.diff(_front(ice)) > 0).all() and (_front(ice)[1:] >= _back(ice)[:-1] - 1e-9).all()  # no overlap
    mixed = generate("mixed", seed)
    assert (mixed.heights >= 0).all() and (mixed.heights <= 0.14).all()


def test_coverage_of_ice_follows_its_range():
    full = generate("ice", 3, family_config("ice", {"coverage_range": [1.0, 1.0]}))
    none = generate("ice", 3, family_config("ice", {"coverage_range": [0.0, 0.0]}))
    assert len(none.heights) == 0 and (height_map(none) == 0).all()
    assert abs((_back(full) - _front(full)).sum() - (5.0 - 0.5)) < 1e-9  # the whole course past clear_x


@pytest.mark.parametrize("name", ["walls", "rubble"])
def test_a_perturbation_moves_every_box_by_at_most_the_shift_and_keeps_the_rest(name):
    t = generate(name, 5)
    p, again, other = perturb(t, 0, 0.02), perturb(t, 0, 0.02), perturb(t, 1, 0.02)
    assert len(p.heights) == len(t.heights)
    np.testing.assert_array_equal(p.heights, t.heights)
    np.testing.assert_array_equal(p.half_sides, t.half_sides)
    moved = np.linalg.norm(p.centers - t.centers, axis=1)
    assert moved.max() <= 0.02 + 1e-12 and moved.max() > 0.005
    np.testing.assert_array_equal(p.centers, again.centers)
    assert not np.array_equal(p.centers, other.centers)
    np.testing.assert_array_equal(perturb(t, 0, 0.0).centers, t.centers)


@pytest.mark.parametrize(("name", "overrides", "words"), [
    ("lava", {}, ["family", "'lava'", "walls"]),
    ("walls", {"height_range": [0.2, 0.1]}, ["walls.height_range", "[0.2, 0.1]", "low <= high"]),
    ("walls", {"spread": 1.5}, ["walls.spread", "1.5", "<= 1"]),
    ("rubble", {"spacing_range": [0.0, 0.3]}, ["rubble.spacing_range", "low > 0"]),
    ("steps", {"steps": 0}, ["steps.steps", "positive integer", "0"]),
    ("ice", {"coverage_range": [0.5, 1.5]}, ["ice.coverage_range", "[0, 1]"]),
    ("mixed", {"x_range": [3.0, 1.0]}, ["mixed.x_range", "low <= high"]),
    ("walls", {"height": 0.1}, ["walls.height", "unknown field"]),
])
def test_bad_family_settings_are_refused_in_one_line(name, overrides, words):
    with pytest.raises(InputError) as err:
        family_config(name, overrides)
    message = str(err.value)
    assert "\n" not in message and all(w in message for w in words), message


def test_a_negative_shift_is_refused():
    with pytest.raises(InputError, match="shift"):
        perturb(generate("walls", 0), 0, -0.01)
