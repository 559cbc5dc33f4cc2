import numpy as np
import pytest

from robocompose.teams.chips import synthetic_chip
from robocompose.teams.decompose import (
    DecomposeConfig,
    Decomposition,
    chip_decomposition,
    decompose,
    decompose_chip,
    mean_purity,
    pixel_centres,
    purity_table,
    regions_table,
    split_chips,
    terrain_features,
)


def disk_terrain(size: int = 60) -> np.ndarray:
    """Plain (2) with a water (0) disk of radius 0.3 in the middle."""
    centres = pixel_centres(size, size)
    return np.where(((centres - 0.5) ** 2).sum(-1) < 0.3**2, 0, 2).astype(np.uint8)


def test_raster_assigns_each_pixel_to_the_centre_nearest_in_position_and_terrain():
    terrain = disk_terrain(30)
    centres = np.array([[0.1, 0.1, 0, 0, 1, 0], [0.9, 0.2, 0, 0, 1, 0], [0.5, 0.9, 1, 0, 0, 0]], dtype=float)
    points = pixel_centres(30, 30)
    for weight in (0.0, 0.4):
        regions = Decomposition(centres, weight).raster(terrain)
        for row, col in [(0, 0), (3, 29), (29, 15), (15, 15), (12, 20)]:
            onehot = np.eye(4)[terrain[row, col]]
            distances = (((centres[:, :2] - points[row, col]) ** 2).sum(1)
                         + weight**2 * ((centres[:, 2:] - onehot) ** 2).sum(1))
            assert regions[row, col] == distances.argmin()
    assert terrain[12, 20] == 0  # a water pixel nearer to plain centre 1 than to water centre 2
    assert Decomposition(centres, 0.0).raster(terrain)[12, 20] == 1  # w = 0: the nearest position wins
    assert Decomposition(centres, 0.4).raster(terrain)[12, 20] == 2  # w > 0: the water centre takes it


def test_the_distances_are_bit_for_bit_the_per_pixel_formula():
    """The distances are computed per column, row and terrain class for speed; every pixel's value must be exactly
    the per-pixel formula's (the decompositions of committed runs depend on these bits)."""
    from robocompose.teams.decompose import _squared_distances

    rng = np.random.default_rng(3)
    terrain = rng.integers(0, 4, (37, 53)).astype(np.uint8)
    centres = np.concatenate([rng.random((7, 2)), rng.dirichlet(np.ones(4), 7)], axis=1)  # (K, 6)
    points = pixel_centres(37, 53).reshape(-1, 2)  # (P, 2)
    planar = ((points[:, None, :] - centres[None, :, :2]) ** 2).sum(-1)  # (P, K)
    shares = centres[:, 2:]
    mismatch = 1.0 - 2.0 * shares.T[terrain.ravel()] + (shares**2).sum(1)[None, :]
    assert np.array_equal(_squared_distances(centres, terrain, 0.3), planar + 0.3**2 * mismatch)


def test_lloyd_steps_even_out_region_areas_of_the_plain_voronoi():
    terrain = np.full((60, 60), 2, dtype=np.uint8)
    raw = decompose(terrain, np.random.default_rng(4), 6, 0.0, 0).raster(terrain)
    relaxed = decompose(terrain, np.random.default_rng(4), 6, 0.0, 10).raster(terrain)
    assert np.bincount(relaxed.ravel()).std() < np.bincount(raw.ravel()).std()


def test_terrain_weight_makes_regions_follow_a_class_boundary_a_voronoi_cuts_across():
    terrain = disk_terrain()
    voronoi = decompose(terrain, np.random.default_rng(0), 2, 0.0, 10).raster(terrain)
    by_terrain = decompose(terrain, np.random.default_rng(0), 2, 1.0, 10).raster(terrain)
    assert mean_purity(terrain, by_terrain, 2) == 1.0  # the disk and the rest
    assert mean_purity(terrain, voronoi, 2) < 0.8  # two half-planes, each half disk


def test_terrain_decomposition_is_purer_than_the_random_seed_voronoi_on_synthetic_chips():
    chips = [synthetic_chip(0, index, size=100) for index in range(4)]
    table = purity_table(chips, DecomposeConfig(n_regions=8, terrain_weight=0.3))
    means = table.groupby("method").purity.mean()
    assert set(table.method) == {"terrain", "voronoi"} and len(table) == 8
    assert means["terrain"] > means["voronoi"] + 0.1


def test_every_region_keeps_pixels_even_when_centres_crowd():
    terrain = np.zeros((6, 6), dtype=np.uint8)
    terrain[:, 3:] = 3
    for seed in range(5):
        regions = decompose(terrain, np.random.default_rng(seed), 12, 1.0, 5).raster(terrain)
        assert (np.bincount(regions.ravel(), minlength=12) > 0).all()
    with pytest.raises(ValueError, match="n_regions: 40 regions"):
        decompose(terrain, np.random.default_rng(0), 40, 1.0, 5)


def test_regions_table_round_trips_the_decomposition():
    chip = synthetic_chip(3, 0, size=80)
    config = DecomposeConfig(n_regions=5, terrain_weight=0.3)
    table = regions_table([chip], config)
    expected = decompose_chip(chip, config).raster(chip.terrain)
    np.testing.assert_array_equal(chip_decomposition(table).raster(chip.terrain), expected)
    np.testing.assert_allclose(table[["water", "mountain", "plain", "city"]].to_numpy(),
                               terrain_features(chip.terrain, expected, 5))
    assert table.n_pixels.sum() == 80 * 80


def test_features_are_terrain_shares_per_region():
    terrain = np.zeros((10, 10), dtype=np.uint8)
    terrain[:, 5:] = 3
    terrain[0, 0] = 1
    regions = np.zeros((10, 10), dtype=np.int64)
    regions[:, 5:] = 1
    features = terrain_features(terrain, regions, 2)
    np.testing.assert_allclose(features.sum(1), 1.0)
    np.testing.assert_allclose(features, [[0.98, 0.02, 0, 0], [0, 0, 0, 1]])
    assert mean_purity(terrain, regions, 2) == pytest.approx(0.99)


def test_split_is_seeded_and_honours_the_fraction():
    ids = [f"c{i}" for i in range(20)]
    split = split_chips(ids, 0.25, seed=1)
    assert split == split_chips(ids, 0.25, seed=1)
    assert sum(v == "test" for v in split.values()) == 5
    assert split != split_chips(ids, 0.25, seed=2)
