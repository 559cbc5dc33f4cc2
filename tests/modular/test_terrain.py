import numpy as np
import pybullet as pb
import pytest

from robocompose.modular.terrain import TerrainConfig, add_terrain, generate_terrain, height_map, poisson_disk
from robocompose.sim.physics import connect


def test_terrain_is_a_function_of_its_seed():
    a, b, c = generate_terrain(7), generate_terrain(7), generate_terrain(8)
    np.testing.assert_array_equal(a.centers, b.centers)
    np.testing.assert_array_equal(a.heights, b.heights)
    assert a.centers.shape != c.centers.shape or not np.array_equal(a.centers, c.centers)


@pytest.mark.parametrize("seed", range(5))
def test_blocks_respect_the_reference_ranges(seed):
    t = generate_terrain(seed, TerrainConfig(max_height_range=(0.0, 0.08)))  # the reference's heights
    assert len(t.centers) > 10
    assert (np.abs(t.centers[:, 0]) >= 0.5).all()
    assert (t.centers[:, 0] >= -1).all() and (t.centers[:, 0] < 9).all() and (np.abs(t.centers[:, 1]) <= 2).all()
    s = 2 * np.sqrt(2)
    assert (t.half_sides >= 0.1 / s).all() and (t.half_sides <= 1 / s).all()
    assert (t.heights >= 0).all() and (t.heights <= 0.08).all()
    gaps = np.linalg.norm(t.centers[:, None] - t.centers[None], axis=-1) + np.eye(len(t.centers)) * 99
    assert gaps.min() >= 0.4


def test_poisson_disk_keeps_its_spacing_and_fills_the_area():
    points = poisson_disk(np.random.default_rng(0), (0, 4), (0, 4), 0.5, 30)
    gaps = np.linalg.norm(points[:, None] - points[None], axis=-1) + np.eye(len(points)) * 99
    assert gaps.min() >= 0.5
    assert len(points) >= 0.5 * 16 / (0.5 ** 2 * np.sqrt(3) / 2) / 2  # at least half of hexagonal packing / 2


def test_height_map_is_50_by_20_and_reads_block_tops():
    t = generate_terrain(3)
    grid = height_map(t)
    assert grid.shape == (50, 20) and grid.dtype == np.float32
    assert grid.max() <= t.max_height + 1e-6 and grid.min() == 0.0
    xs, ys = np.linspace(-1, 9, 50), np.linspace(-2, 2, 20)
    i, j = np.unravel_index(np.argmax(grid), grid.shape)
    inside = (np.abs(xs[i] - t.centers[:, 0]) <= t.half_sides[:, 0]) & (np.abs(ys[j] - t.centers[:, 1])
                                                                         <= t.half_sides[:, 1])
    assert grid[i, j] == pytest.approx(t.heights[inside].max())
    assert (grid[np.abs(xs) < 0.5 - 0.354] == 0).all()  # the start strip is clear


def test_flat_config_gives_no_blocks_in_pybullet():
    t = generate_terrain(0, TerrainConfig(max_height_range=(0.0, 0.0)))
    c = connect()
    try:
        _, blocks = add_terrain(c, t)
        assert blocks == [] and height_map(t).max() == 0
    finally:
        pb.disconnect(physicsClientId=c)


def test_blocks_stand_where_the_generator_put_them():
    t = generate_terrain(4, TerrainConfig(max_height_range=(0.08, 0.08)))
    c = connect()
    try:
        _, blocks = add_terrain(c, t)
        assert len(blocks) == -(-len(t.centers) // 16) > 1
        # Every block's centre reads at least its own height (overlapping blocks: the taller one).
        starts = [[x, y, 1.0] for x, y in t.centers]
        ends = [[x, y, -0.5] for x, y in t.centers]
        tops = np.array([hit[3][2] for hit in pb.rayTestBatch(starts, ends, physicsClientId=c)])
        assert (tops >= t.heights - 1e-4).all() and np.isclose(tops, t.heights, atol=1e-4).mean() > 0.8
    finally:
        pb.disconnect(physicsClientId=c)


def test_bad_ranges_name_the_field():
    with pytest.raises(ValueError, match="spacing_range"):
        TerrainConfig(spacing_range=(1.0, 0.4))


def test_the_widened_heights_give_near_flat_and_rough_terrains():
    # H ~ U(0, 0.2) per terrain (the reference: U(0, 0.08)): some terrains stay below wheel-rolling heights,
    # others carry blocks taller than a wheel's radius.
    tallest = [generate_terrain(seed).max_height for seed in range(1000, 1008)]
    assert max(tallest) <= 0.2 and min(tallest) < 0.05 and max(tallest) > 0.105
