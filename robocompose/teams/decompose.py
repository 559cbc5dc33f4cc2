"""Voronoi decomposition of a terrain chip into K regions and its K x 4 terrain-feature matrix.

Seeds: K points drawn uniformly in the unit square, then `lloyd_iterations` Lloyd steps (each seed
moves to the centroid of its cell) so regions have similar areas. A pixel belongs to the region of
its nearest seed (pixel centres at ((col + 0.5) / W, (row + 0.5) / H)), which is the Voronoi diagram
clipped to the square and rasterised; ties go to the lower region index. Everything about a chip's
regions is fixed by its seed points, so the regions table stores those and `region_raster`
recomputes the raster exactly.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import pandas as pd

from robocompose.io.errors import InputError, check_field
from robocompose.teams.chips import Chip

N_TERRAINS = 4
# Regions per chip at most: the (H, W, K, 2) distance raster of a 300 x 300 chip takes 1.4 MB per region, and a
# region of the 100 x 100 Lloyd grid keeps >= 150 cells on average.
MAX_REGIONS = 64


@dataclass(frozen=True)
class DecomposeConfig:
    n_regions: int = 8  # K, Voronoi cells per chip (1..MAX_REGIONS)
    lloyd_iterations: int = 10  # Lloyd relaxation steps of the seeds (0: plain random Voronoi)
    test_fraction: float = 0.25  # share of chips put in the test split, strictly between 0 and 1
    seed: int = 0  # seeds the Voronoi seed points and the split

    def __post_init__(self) -> None:
        check_field(1 <= self.n_regions <= MAX_REGIONS, "n_regions", f"an integer in 1..{MAX_REGIONS}", self.n_regions)
        check_field(self.lloyd_iterations >= 0, "lloyd_iterations", "an integer >= 0", self.lloyd_iterations)
        check_field(0 < self.test_fraction < 1, "test_fraction", "a share strictly between 0 and 1 (test chips / "
                    "all chips)", self.test_fraction)
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)


def pixel_centres(height: int, width: int) -> np.ndarray:
    """(H, W, 2) pixel centres (x = column, y = row) in the unit square."""
    rows, cols = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width,
                             indexing="ij")
    return np.stack([cols, rows], axis=-1)


def region_raster(seeds: np.ndarray, height: int, width: int) -> np.ndarray:
    """(H, W) int64 region index of every pixel: its nearest seed of (K, 2) `seeds`."""
    centres = pixel_centres(height, width)  # (H, W, 2)
    distances = ((centres[:, :, None, :] - seeds[None, None]) ** 2).sum(-1)  # (H, W, K)
    return distances.argmin(-1)


def voronoi_seeds(rng: np.random.Generator, n_regions: int, lloyd_iterations: int,
                  resolution: int = 100) -> np.ndarray:
    """(K, 2) seed points: uniform draws relaxed by Lloyd steps on a resolution^2 pixel grid."""
    seeds = rng.random((n_regions, 2))
    centres = pixel_centres(resolution, resolution).reshape(-1, 2)  # (P, 2)
    for _ in range(lloyd_iterations):
        labels = region_raster(seeds, resolution, resolution).ravel()
        counts = np.bincount(labels, minlength=n_regions)
        sums = np.stack([np.bincount(labels, centres[:, d], minlength=n_regions) for d in range(2)], -1)
        seeds = np.where(counts[:, None] > 0, sums / np.maximum(counts, 1)[:, None], seeds)
    return seeds


def chip_seeds(chip_id: str, config: DecomposeConfig) -> np.ndarray:
    """(K, 2) Voronoi seeds of a chip, drawn from Generator((config.seed, hash of the chip id))."""
    chip_hash = int(hashlib.sha1(chip_id.encode()).hexdigest()[:12], 16)
    return voronoi_seeds(np.random.default_rng([config.seed, chip_hash]), config.n_regions,
                         config.lloyd_iterations)


def terrain_features(terrain: np.ndarray, regions: np.ndarray, n_regions: int) -> np.ndarray:
    """(K, 4) terrain-class distribution of each region (rows sum to 1) from (H, W) maps."""
    joint = np.bincount(regions.ravel() * N_TERRAINS + terrain.ravel(), minlength=n_regions * N_TERRAINS)
    counts = joint.reshape(n_regions, N_TERRAINS).astype(np.float64)
    if (counts.sum(1) == 0).any():
        raise InputError(f"n_regions {n_regions}: a Voronoi region holds no pixel of the chip (pixels per region "
                         f"{counts.sum(1).astype(int).tolist()}); expected fewer regions")
    return counts / counts.sum(1, keepdims=True)


def split_chips(chip_ids: list[str], test_fraction: float, seed: int) -> dict[str, str]:
    """Map each chip id to "train" or "test": a seeded shuffle, the first round(n * f) are test."""
    order = np.random.default_rng(seed).permutation(len(chip_ids))
    n_test = int(round(len(chip_ids) * test_fraction))
    return {chip_ids[i]: ("test" if rank < n_test else "train") for rank, i in enumerate(order)}


def regions_table(chips: list[Chip], config: DecomposeConfig) -> pd.DataFrame:
    """The "regions" table: one row per (chip, region) with split, seed point, size and terrain shares."""
    split = split_chips([chip.chip_id for chip in chips], config.test_fraction, config.seed)
    rows = []
    for chip in chips:
        seeds = chip_seeds(chip.chip_id, config)
        regions = region_raster(seeds, *chip.classes.shape)
        features = terrain_features(chip.terrain, regions, config.n_regions)
        sizes = np.bincount(regions.ravel(), minlength=config.n_regions)
        for region in range(config.n_regions):
            rows.append((chip.chip_id, chip.source, split[chip.chip_id], region, *seeds[region],
                         sizes[region], *features[region]))
    columns = ["chip_id", "source", "split", "region", "seed_x", "seed_y", "n_pixels",
               "water", "mountain", "plain", "city"]
    return pd.DataFrame(rows, columns=columns)
