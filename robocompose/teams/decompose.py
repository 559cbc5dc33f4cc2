"""Decomposition of a terrain chip into K regions that follow its terrain, and the K x 4 feature matrix.

Thesis 5.2: the sub-regions come from "voronoi partitioning of target regions based on terrain
features". We partition in a joint space of position and terrain class: pixel p (centre x_p in the
unit square, terrain t_p) is described by (x_p, w * onehot(t_p)), a region centre by (x_c, w * s_c)
with s_c a distribution over the 4 terrains, and a pixel belongs to the centre nearest in that space,

    d(p, c)^2 = |x_p - x_c|^2 + w^2 |onehot(t_p) - s_c|^2,

i.e. the Voronoi diagram of the centres in the joint space (ties go to the lower region index).
w = `terrain_weight` is in chip sides: a pixel whose terrain differs from a centre's (pure) class is
as far from it as a pixel sqrt(2) w away in the plane, so regions bend along terrain boundaries; w = 0
is the plain Voronoi diagram of the positions. Centres start at K uniform random points (terrain
part: the class of the pixel under them) and take `lloyd_iterations` Lloyd steps in the joint space
(each centre moves to the mean of its pixels: their mean position and their terrain shares), which is
k-means on the pixel features (SLIC superpixels with a categorical colour). A centre left without
pixels restarts at the worst-served pixel (farthest from its own centre), which it then owns, so
every region keeps pixels. The steps run on a 100 x 100 grid of the chip's pixels. With w = 0 this
is the random-seed Voronoi with Lloyd relaxation of round 1.

A chip's regions are fixed by its centres and w, so the regions table stores those and
`Decomposition.raster` recomputes the raster exactly. Region purity (the share of a region's pixels
in its most common terrain) measures how well regions follow the terrain.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.io.errors import InputError, check_field
from robocompose.teams.chips import Chip

N_TERRAINS = 4
# Regions per chip at most: the full-size raster keeps (H*W, K) distance arrays, ~0.7 MB per region each for a
# 300 x 300 chip, and every region should keep pixels of the 100 x 100 Lloyd grid (>= 150 on average).
MAX_REGIONS = 64
TERRAIN_COLUMNS = ("water", "mountain", "plain", "city")
CENTRE_COLUMNS = ("seed_x", "seed_y", "seed_water", "seed_mountain", "seed_plain", "seed_city")


@dataclass(frozen=True)
class DecomposeConfig:
    n_regions: int = 8  # K regions per chip (1..MAX_REGIONS)
    terrain_weight: float = 0.3  # w, chip sides a terrain mismatch counts for (0 = plain Voronoi)
    lloyd_iterations: int = 10  # Lloyd (k-means) steps of the centres in the joint space
    test_fraction: float = 0.25  # share of chips put in the test split, strictly between 0 and 1
    seed: int = 0  # seeds the initial centres and the split

    def __post_init__(self) -> None:
        check_field(1 <= self.n_regions <= MAX_REGIONS, "n_regions", f"an integer in 1..{MAX_REGIONS}", self.n_regions)
        check_field(self.terrain_weight >= 0, "terrain_weight", "a number >= 0", self.terrain_weight)
        check_field(self.lloyd_iterations >= 0, "lloyd_iterations", "an integer >= 0", self.lloyd_iterations)
        check_field(0 < self.test_fraction < 1, "test_fraction", "a share strictly between 0 and 1 (test chips / "
                    "all chips)", self.test_fraction)
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)


def pixel_centres(height: int, width: int) -> np.ndarray:
    """(H, W, 2) pixel centres (x = column, y = row) in the unit square."""
    rows, cols = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width,
                             indexing="ij")
    return np.stack([cols, rows], axis=-1)


def _squared_distances(centres: np.ndarray, terrain: np.ndarray, terrain_weight: float) -> np.ndarray:
    """(H*W, K) joint-space squared distance of every pixel of an (H, W) terrain map to (K, 6) centres:
    (x - cx)^2 + (y - cy)^2 + w^2 |onehot(t) - s|^2, each term as pixel_centres' coordinates give it."""
    height, width = terrain.shape
    xs, ys = (np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height  # pixel_centres' columns, rows
    dx2 = (xs[:, None] - centres[:, 0]) ** 2  # (W, K)
    dy2 = (ys[:, None] - centres[:, 1]) ** 2  # (H, K)
    shares = centres[:, 2:]  # (K, 4)
    # |onehot(t) - s|^2 = 1 - 2 s_t + |s|^2 depends on the pixel's terrain t only: a (4, K) table
    mismatch = 1.0 - 2.0 * shares.T + (shares**2).sum(1)[None, :]
    # the same sums of the same terms as per pixel, in the same order: the same bits, ~6x faster
    distances = dx2[None, :, :] + dy2[:, None, :]  # (H, W, K)
    distances += np.take(terrain_weight**2 * mismatch, terrain, axis=0)
    return distances.reshape(height * width, -1)


@dataclass(frozen=True)
class Decomposition:
    """A chip's regions: (K, 6) centres [x, y, water, mountain, plain, city shares] and the weight w."""

    centres: np.ndarray
    terrain_weight: float

    @property
    def n_regions(self) -> int:
        return len(self.centres)

    def raster(self, terrain: np.ndarray) -> np.ndarray:
        """(H, W) int64 region index of every pixel of an (H, W) terrain map."""
        return _squared_distances(self.centres, terrain, self.terrain_weight).argmin(1).reshape(terrain.shape)


def decompose(terrain: np.ndarray, rng: np.random.Generator, n_regions: int, terrain_weight: float,
              lloyd_iterations: int, resolution: int = 100) -> Decomposition:
    """Regions of an (H, W) terrain map: random centres relaxed by Lloyd steps in the joint space.

    The steps run on the pixels nearest to a resolution x resolution grid of centres (for a 300 px chip
    every third pixel, whose centres are exactly the grid's), the raster is then full size.
    """
    rows = ((np.arange(min(resolution, terrain.shape[0])) + 0.5) * terrain.shape[0]
            / min(resolution, terrain.shape[0])).astype(int)
    cols = ((np.arange(min(resolution, terrain.shape[1])) + 0.5) * terrain.shape[1]
            / min(resolution, terrain.shape[1])).astype(int)
    terrain = terrain[np.ix_(rows, cols)]  # (h, w) the grid's pixels
    height, width = terrain.shape
    flat_terrain = terrain.ravel().astype(np.int64)
    onehot = np.eye(N_TERRAINS)[flat_terrain]  # (P, 4)
    features = np.concatenate([pixel_centres(height, width).reshape(-1, 2), onehot], axis=1)  # (P, 6)
    start = rng.random((n_regions, 2))  # (K, 2)
    start_pixel = (np.minimum((start[:, 1] * height).astype(int), height - 1) * width
                   + np.minimum((start[:, 0] * width).astype(int), width - 1))
    centres = np.concatenate([start, onehot[start_pixel]], axis=1)  # (K, 6)
    if n_regions > len(features):
        raise InputError(f"n_regions: {n_regions} regions cannot split a {height} x {width} chip")
    columns = [np.ascontiguousarray(features[:, d]) for d in range(6)]  # bincount's weights, copied once
    steps, restarts = 0, 0
    while True:
        distances = _squared_distances(centres, terrain, terrain_weight)  # (P, K)
        labels = distances.argmin(1)
        counts = np.bincount(labels, minlength=n_regions)
        empty = np.flatnonzero(counts == 0)
        if len(empty) and restarts < n_regions:  # restart at the worst-served pixels, which they then own
            restarts += 1
            served = distances[np.arange(len(labels)), labels]  # (P,)
            for region, pixel in zip(empty, np.argsort(-served, kind="stable"), strict=False):
                centres[region] = features[pixel]
            continue
        if steps == lloyd_iterations:
            break
        sums = np.stack([np.bincount(labels, column, minlength=n_regions) for column in columns], -1)  # (K, 6)
        centres = np.where(counts[:, None] > 0, sums / np.maximum(counts, 1)[:, None], centres)
        steps += 1
    return Decomposition(centres, terrain_weight)


def decompose_chip(chip: Chip, config: DecomposeConfig) -> Decomposition:
    """A chip's regions, its centres drawn from Generator((config.seed, hash of the chip id))."""
    chip_hash = int(hashlib.sha1(chip.chip_id.encode()).hexdigest()[:12], 16)
    return decompose(chip.terrain, np.random.default_rng([config.seed, chip_hash]), config.n_regions,
                     config.terrain_weight, config.lloyd_iterations)


def terrain_features(terrain: np.ndarray, regions: np.ndarray, n_regions: int) -> np.ndarray:
    """(K, 4) terrain-class distribution of each region (rows sum to 1) from (H, W) maps."""
    joint = np.bincount(regions.ravel() * N_TERRAINS + terrain.ravel(), minlength=n_regions * N_TERRAINS)
    counts = joint.reshape(n_regions, N_TERRAINS).astype(np.float64)
    if (counts.sum(1) == 0).any():
        raise InputError(f"n_regions {n_regions}: a region holds no pixel of the chip (pixels per region "
                         f"{counts.sum(1).astype(int).tolist()}); expected fewer regions")
    return counts / counts.sum(1, keepdims=True)


def mean_purity(terrain: np.ndarray, regions: np.ndarray, n_regions: int) -> float:
    """Mean over regions of the share of the region's pixels in its most common terrain."""
    return float(terrain_features(terrain, regions, n_regions).max(1).mean())


def split_chips(chip_ids: list[str], test_fraction: float, seed: int) -> dict[str, str]:
    """Map each chip id to "train" or "test": a seeded shuffle, the first round(n * f) are test."""
    order = np.random.default_rng(seed).permutation(len(chip_ids))
    n_test = int(round(len(chip_ids) * test_fraction))
    return {chip_ids[i]: ("test" if rank < n_test else "train") for rank, i in enumerate(order)}


def regions_table(chips: list[Chip], config: DecomposeConfig) -> pd.DataFrame:
    """The "regions" table: one row per (chip, region) with split, centre, size and terrain shares."""
    split = split_chips([chip.chip_id for chip in chips], config.test_fraction, config.seed)
    rows = []
    for chip in chips:
        decomposition = decompose_chip(chip, config)
        regions = decomposition.raster(chip.terrain)
        features = terrain_features(chip.terrain, regions, config.n_regions)
        sizes = np.bincount(regions.ravel(), minlength=config.n_regions)
        for region in range(config.n_regions):
            rows.append((chip.chip_id, chip.source, split[chip.chip_id], region,
                         *decomposition.centres[region], config.terrain_weight, sizes[region],
                         *features[region]))
    columns = ["chip_id", "source", "split", "region", *CENTRE_COLUMNS, "terrain_weight", "n_pixels",
               *TERRAIN_COLUMNS]
    return pd.DataFrame(rows, columns=columns)


def chip_decomposition(rows: pd.DataFrame) -> Decomposition:
    """The Decomposition of one chip from its rows of the regions table."""
    rows = rows.sort_values("region")
    return Decomposition(rows[list(CENTRE_COLUMNS)].to_numpy(dtype=np.float64),
                         float(rows.terrain_weight.iloc[0]))


def purity_table(chips: list[Chip], config: DecomposeConfig) -> pd.DataFrame:
    """Mean region purity of every chip under `config` and under the plain Voronoi (w = 0), same seeds:
    the "regions_purity" table (chip_id, method, purity)."""
    rows = []
    for method, weight in [("terrain", config.terrain_weight), ("voronoi", 0.0)]:
        for chip in chips:
            decomposition = decompose_chip(chip, DecomposeConfig(config.n_regions, weight,
                                                                 config.lloyd_iterations, seed=config.seed))
            rows.append((chip.chip_id, method, mean_purity(chip.terrain, decomposition.raster(chip.terrain),
                                                           config.n_regions)))
    return pd.DataFrame(rows, columns=["chip_id", "method", "purity"])
