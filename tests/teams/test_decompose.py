import numpy as np

from robocompose.teams.decompose import (
    pixel_centres,
    region_raster,
    split_chips,
    terrain_features,
    voronoi_seeds,
)


def test_raster_assigns_each_pixel_to_its_nearest_seed():
    seeds = np.array([[0.1, 0.1], [0.9, 0.2], [0.5, 0.9]])
    regions = region_raster(seeds, 30, 40)
    centres = pixel_centres(30, 40)
    assert regions.shape == (30, 40)
    for row, col in [(0, 0), (3, 39), (29, 20), (15, 20)]:
        distances = ((seeds - centres[row, col]) ** 2).sum(1)
        assert regions[row, col] == distances.argmin()


def test_lloyd_steps_even_out_region_areas():
    rng_seed = 4
    raw = region_raster(voronoi_seeds(np.random.default_rng(rng_seed), 6, 0), 60, 60)
    relaxed = region_raster(voronoi_seeds(np.random.default_rng(rng_seed), 6, 10), 60, 60)
    assert np.bincount(relaxed.ravel()).std() < np.bincount(raw.ravel()).std()


def test_features_are_terrain_shares_per_region():
    terrain = np.zeros((10, 10), dtype=np.uint8)
    terrain[:, 5:] = 3
    terrain[0, 0] = 1
    regions = np.zeros((10, 10), dtype=np.int64)
    regions[:, 5:] = 1
    features = terrain_features(terrain, regions, 2)
    np.testing.assert_allclose(features.sum(1), 1.0)
    np.testing.assert_allclose(features, [[0.98, 0.02, 0, 0], [0, 0, 0, 1]])


def test_split_is_seeded_and_honours_the_fraction():
    ids = [f"c{i}" for i in range(20)]
    split = split_chips(ids, 0.25, seed=1)
    assert split == split_chips(ids, 0.25, seed=1)
    assert sum(v == "test" for v in split.values()) == 5
    assert split != split_chips(ids, 0.25, seed=2)
