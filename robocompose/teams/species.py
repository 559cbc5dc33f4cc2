"""The robot bank of thesis Table 5.3: species, their terrain speeds, allocations and deployment cost.

Terrain ids everywhere in `robocompose.teams`: 0 Water, 1 Mountain, 2 Plain, 3 City (Table 5.3's
column order). Species ids: 0 ground, 1 aerial, 2 aquatic (its row order).

Speed scaling (one choice, used everywhere): a speed of v m/s lets a robot move at most
v * SPEED_SCALE unit-square widths between two consecutive observations. SPEED_SCALE = 0.3 / 100 is
the public code's scaling, so the fastest robot (50 m/s) moves 0.15 of the chip side per step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocompose.io.errors import InputError

TERRAINS: tuple[str, ...] = ("Water", "Mountain", "Plain", "City")
SPEED_SCALE = 0.3 / 100


@dataclass(frozen=True)
class Species:
    name: str
    speeds: tuple[float, float, float, float]  # max speed (m/s) on Water, Mountain, Plain, City
    coverage_weight: float  # weight of this species' observations in its team's coverage


SPECIES: tuple[Species, ...] = (
    Species("ground", (0.0, 20.0, 40.0, 50.0), 20.0),
    Species("aerial", (50.0, 50.0, 50.0, 30.0), 10.0),
    Species("aquatic", (50.0, 0.0, 0.0, 30.0), 20.0),
)


def step_lengths() -> np.ndarray:
    """(O, M) max displacement per observation step, unit-square widths, for species x terrain."""
    return np.array([s.speeds for s in SPECIES], dtype=np.float64) * SPEED_SCALE


def coverage_weights() -> np.ndarray:
    """(O,) coverage weight per species."""
    return np.array([s.coverage_weight for s in SPECIES], dtype=np.float64)


def allocation_to_counts(fractions: np.ndarray, robots_per_species: int) -> np.ndarray:
    """Turn allocation matrices into integer robot counts.

    fractions: (..., K, O) non-negative; entry (i, j) is the fraction of species j sent to region i.
    A species whose fractions sum above 1 over the regions is scaled down to sum 1 (no robot is sent
    twice). Counts are round(N * fraction) (thesis 5.2); if rounding up makes a species exceed its N
    robots, the entries rounded up the most lose one robot each until it fits.
    Returns (..., K, O) int64 counts with counts.sum(-2) <= robots_per_species.
    """
    fractions = np.asarray(fractions, dtype=np.float64)
    if fractions.ndim < 2 or (fractions < 0).any() or not np.isfinite(fractions).all():
        raise ValueError(f"allocation must be a (..., K, O) array of finite non-negative fractions, "
                         f"got shape {fractions.shape}")
    column_sums = fractions.sum(axis=-2, keepdims=True)
    wanted = robots_per_species * fractions / np.maximum(column_sums, 1.0)  # (..., K, O)
    counts = np.rint(wanted).astype(np.int64)
    excess = np.maximum(counts.sum(axis=-2) - robots_per_species, 0)  # (..., O)
    if excess.any():
        rounded_up_rank = np.argsort(np.argsort(wanted - counts, axis=-2), axis=-2)  # 0 = most rounded up
        counts -= (rounded_up_rank < excess[..., None, :]).astype(np.int64)
    return counts


def deployment_cost(counts: np.ndarray) -> np.ndarray:
    """(...,) deployment cost of (..., K, O) counts: every deployed robot costs 1."""
    return np.asarray(counts).sum(axis=(-2, -1))


def parse_allocation(text: str) -> np.ndarray:
    """Parse "a,b,c;d,e,f;..." (one row of species fractions per region) into a (K, O) array.

    Entry (i, j) is the fraction of species j's robots sent to region i: a number in [0, 1], and each species'
    fractions sum to at most 1 over the regions (robots not sent stay undeployed). Anything else is an
    InputError; nothing is rescaled.
    """
    names = ",".join(f"f_{s.name}" for s in SPECIES)
    rows = [row.split(",") for row in text.strip().split(";") if row.strip()]
    if not rows or any(len(row) != len(SPECIES) for row in rows):
        raise InputError(f"--allocation {text!r}: expected rows '{names}' separated by ';', one row per region, "
                         f"{len(SPECIES)} numbers per row")
    try:
        fractions = np.array([[float(v) for v in row] for row in rows])  # (K, O)
    except ValueError as err:
        raise InputError(f"--allocation {text!r}: {err}") from None
    bad = ~np.isfinite(fractions) | (fractions < 0) | (fractions > 1)
    if bad.any():
        region, species = np.argwhere(bad)[0]
        raise InputError(f"--allocation: region {region}, {SPECIES[species].name}: expected a fraction in [0, 1], "
                         f"found {fractions[region, species]:g}")
    sums = fractions.sum(axis=0)  # (O,)
    over = np.flatnonzero(sums > 1 + 1e-9)
    if over.size:
        species = over[0]
        raise InputError(f"--allocation: the {SPECIES[species].name} fractions sum to {sums[species]:g} over the "
                         f"regions, expected at most 1 (each is a share of that species' robots; nothing is "
                         f"rescaled)")
    return fractions
