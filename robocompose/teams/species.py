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


def parse_allocation(text: str, n_species: int = len(SPECIES)) -> np.ndarray:
    """Parse "a,b,c;d,e,f;..." (one row of species fractions per region) into a (K, O) array."""
    rows = [row.split(",") for row in text.strip().split(";") if row.strip()]
    if not rows or any(len(row) != n_species for row in rows):
        raise ValueError(f"--allocation {text!r}: expected rows 'f_ground,f_aerial,f_aquatic' "
                         f"separated by ';', one row per region, {n_species} numbers per row")
    try:
        return np.array([[float(v) for v in row] for row in rows])
    except ValueError as err:
        raise ValueError(f"--allocation {text!r}: {err}") from None
