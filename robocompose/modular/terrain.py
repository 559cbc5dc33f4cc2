"""Block terrains of thesis 5.1 (the task) and their 50 x 20 height-map encoding.

Blocks are placed by Poisson-disk sampling (Bridson's algorithm) on the 10 m x 4 m course x in [-1, 9],
y in [-2, 2], with none whose centre has |x| < 0.5 (the robot starts at the origin). Per terrain: a minimum
spacing r ~ U(0.4, 1.0) and a maximum height H ~ U(0, 0.4) (the default profile; `max_height_range`); per block:
half-sides (x and y drawn independently) ~ U(0.1, 1) / (2 sqrt 2) and height ~ U(0, H). A terrain is a pure
function of its seed and `TerrainConfig`.

Deviation from the reference: H ~ U(0, 0.08) there. Under those heights 10.5 cm wheels roll over every block
and one wheeled design is best on every terrain (nothing for a terrain-conditioned generator to learn); under
H ~ U(0, 0.2) leg-wheel designs are still near-optimal everywhere (the best design on average loses 4% of the
mean optimum); under H ~ U(0, 0.4) near-flat terrains favour wheels, rough ones leg-wheels and legs, and the
best design depends on the terrain (`robocompose.modular.experiments.terrain_study`; docs/modular.md). The
original code itself carries a commented "high" setting of 0.15 m.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from robocompose.io.errors import InputError

GRID_X, GRID_Y = 50, 20  # height-map samples along x and y


@dataclass(frozen=True)
class TerrainConfig:
    """Ranges of the block generator (thesis 5.1 / the original code)."""

    x_range: tuple[float, float] = (-1.0, 9.0)  # m, course extent along x
    y_range: tuple[float, float] = (-2.0, 2.0)  # m, course extent along y
    clear_x: float = 0.5  # m, no block centre with |x| < clear_x
    spacing_range: tuple[float, float] = (0.4, 1.0)  # m, Poisson-disk minimum distance, drawn per terrain
    side_range: tuple[float, float] = (0.1, 1.0)  # block half-side = U(side_range) / (2 sqrt 2)
    # m, H per terrain; block heights ~ U(0, H). Reference 0.08; the default profile sets (0, 0.4). This default
    # stays: it enters the physics digest, so changing it would orphan every committed exhaustive table.
    max_height_range: tuple[float, float] = (0.0, 0.2)
    friction: float = 0.7  # block lateral friction
    ground_friction: float = 0.8
    candidates: int = 30  # Bridson's k: candidates tried around each active point

    def __post_init__(self):
        for name in ("x_range", "y_range", "spacing_range", "side_range", "max_height_range"):
            if len(getattr(self, name)) != 2:
                raise InputError(f"{name}: expected [low, high], found {getattr(self, name)}")
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))  # YAML gives lists
            lo, hi = getattr(self, name)
            if not lo <= hi:
                raise InputError(f"{name}: expected low <= high, found {getattr(self, name)}")
        if self.spacing_range[0] <= 0:
            raise InputError(f"spacing_range: expected a positive minimum distance, found {self.spacing_range}")

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Terrain:
    """Blocks of one terrain: (N, 2) centres, (N, 2) half-sides in x and y, (N,) heights; its seed."""

    seed: int
    centers: np.ndarray
    half_sides: np.ndarray
    heights: np.ndarray
    config: TerrainConfig

    @property
    def task_id(self) -> str:
        return f"blocks-{self.seed}"

    @property
    def max_height(self) -> float:
        return float(self.heights.max()) if len(self.heights) else 0.0


def poisson_disk(rng: np.random.Generator, x_range, y_range, radius: float, candidates: int) -> np.ndarray:
    """(N, 2) points in the rectangle, pairwise at least `radius` apart (Bridson 2007), in generation order."""
    cell = radius / math.sqrt(2)
    (x0, x1), (y0, y1) = x_range, y_range
    nx, ny = int(math.ceil((x1 - x0) / cell)), int(math.ceil((y1 - y0) / cell))
    grid = -np.ones((nx, ny), dtype=np.int64)  # index of the point in each cell, -1 if empty
    points: list[tuple[float, float]] = []

    def add(p: tuple[float, float]) -> None:
        grid[min(int((p[0] - x0) / cell), nx - 1), min(int((p[1] - y0) / cell), ny - 1)] = len(points)
        points.append(p)

    def far_enough(p: tuple[float, float]) -> bool:
        i, j = int((p[0] - x0) / cell), int((p[1] - y0) / cell)
        for a in range(max(i - 2, 0), min(i + 3, nx)):
            for b in range(max(j - 2, 0), min(j + 3, ny)):
                k = grid[a, b]
                if k >= 0 and (points[k][0] - p[0]) ** 2 + (points[k][1] - p[1]) ** 2 < radius ** 2:
                    return False
        return True

    add((float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1))))
    active = [0]
    while active:
        k = active[int(rng.integers(len(active)))]
        for _ in range(candidates):
            r, angle = rng.uniform(radius, 2 * radius), rng.uniform(0, 2 * math.pi)
            p = (points[k][0] + r * math.cos(angle), points[k][1] + r * math.sin(angle))
            if x0 <= p[0] < x1 and y0 <= p[1] < y1 and far_enough(p):
                add(p)
                active.append(len(points) - 1)
                break
        else:
            active.remove(k)
    return np.array(points, dtype=np.float64).reshape(-1, 2)


def generate_terrain(seed: int, config: TerrainConfig = TerrainConfig()) -> Terrain:
    """The block terrain of `seed`."""
    rng = np.random.default_rng([seed, 5101])  # 5101: this generator's stream, apart from other uses of seed
    spacing = rng.uniform(*config.spacing_range)
    max_height = rng.uniform(*config.max_height_range)
    centers = poisson_disk(rng, config.x_range, config.y_range, spacing, config.candidates)
    centers = centers[np.abs(centers[:, 0]) >= config.clear_x]
    half_sides = rng.uniform(*config.side_range, size=(len(centers), 2)) / (2 * math.sqrt(2))
    heights = rng.uniform(0.0, max_height, size=len(centers))
    return Terrain(seed, centers, half_sides, heights, config)


def height_map(terrain: Terrain) -> np.ndarray:
    """(50, 20) float32 heights at x = linspace(x_range, 50), y = linspace(y_range, 20): the task encoding."""
    xs = np.linspace(*terrain.config.x_range, GRID_X)
    ys = np.linspace(*terrain.config.y_range, GRID_Y)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")  # (50, 20) each
    inside = ((np.abs(gx[..., None] - terrain.centers[:, 0]) <= terrain.half_sides[:, 0])
              & (np.abs(gy[..., None] - terrain.centers[:, 1]) <= terrain.half_sides[:, 1]))  # (50, 20, N)
    return np.where(inside, terrain.heights, 0.0).max(axis=-1, initial=0.0).astype(np.float32)


CHUNK = 16  # pybullet silently keeps only 16 shapes of a collision shape array (and crashes on more visuals)


def add_terrain(client: int, terrain: Terrain, visual: bool = False) -> tuple[int, list[int]]:
    """Ground plane and the blocks (static compound bodies of up to 16 blocks) in a pybullet client.

    Returns (ground id, block body ids).
    """
    import pybullet as pb

    from robocompose.sim.physics import add_floor

    ground = add_floor(client, half_extents=(40.0, 10.0), friction=terrain.config.ground_friction)
    keep = terrain.heights > 1e-4  # a block of no height is no obstacle, and Bullet dislikes flat boxes
    centers, half_sides, heights = terrain.centers[keep], terrain.half_sides[keep], terrain.heights[keep]
    # Blocks stand on the ground: box centre at half its height.
    positions = [[float(c[0]), float(c[1]), float(h / 2)] for c, h in zip(centers, heights, strict=True)]
    extents = [[float(s[0]), float(s[1]), float(h / 2)] for s, h in zip(half_sides, heights, strict=True)]
    bodies = []
    for start in range(0, len(positions), CHUNK):
        box_extents, box_positions = extents[start:start + CHUNK], positions[start:start + CHUNK]
        k = len(box_extents)
        shape = pb.createCollisionShapeArray([pb.GEOM_BOX] * k, halfExtents=box_extents,
                                             collisionFramePositions=box_positions, physicsClientId=client)
        look = -1
        if visual:
            look = pb.createVisualShapeArray([pb.GEOM_BOX] * k, halfExtents=box_extents,
                                             visualFramePositions=box_positions,
                                             rgbaColors=[[0.55, 0.45, 0.35, 1]] * k, physicsClientId=client)
        body = pb.createMultiBody(0, shape, look, basePosition=[0, 0, 0], physicsClientId=client)
        pb.changeDynamics(body, -1, lateralFriction=terrain.config.friction, physicsClientId=client)
        bodies.append(body)
    return ground, bodies
