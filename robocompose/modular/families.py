"""Terrain families beyond the thesis's block world, built to let the terrain decide the design (issue 46, item 3).

In the block world the terrain explains 58% of the variance of distance but which design wins barely depends on
it: blocks are scattered, so a robot drives around or between them and the controller's chaos decides more than
the terrain. Each family here is an obstacle no design can avoid (it spans the course's width) or a field it
cannot dodge, with one or two per-terrain knobs that are visible in the 50 x 20 height map (`terrain.height_map`,
the task tensor) and that should move the best design from wheels to legs or leg-wheels. The physics, controller
and episode are the block world's (`evaluate.rollouts` on a `Terrain` of boxes): only the boxes differ.

Scales that matter (robot.py): wheels have a 10.5 cm radius (a wheel rolls onto a step of well under its radius),
a leg's shoulder swings +-pi/12, so a foot lifts about 0.365 sin(pi/12) ~ 9 cm, and the chassis rides ~26 cm
above the ground. Families:

- `walls`: full-width walls across the course, each H * U(1 - spread, 1) tall, H ~ U(height_range) per terrain:
  below a few cm wheels roll over at full speed, around a wheel's radius only modules that lift pass.
- `steps`: a staircase up, risers R ~ U(riser_range) and treads T ~ U(tread_range) per terrain, `steps` risers
  then a plateau. Short treads with low risers approximate a ramp (slope R/T): a true slope cannot be built from
  axis-aligned boxes on a plane, so there is no `slope` family.
- `rubble`: a dense Poisson-disk field of small boxes (half-sides in `side_range`, heights U(0, H), H per
  terrain): too dense to drive around, with gaps that can wedge a wheel and edges that trip a foot.
- `ice`: full-width 5 mm sheets of low friction (`friction`, 0.1) covering a share ~ U(coverage_range) of the
  course: wheels need traction to drive, feet to push. The sheets are the only boxes, so their extent shows in
  the height map; their friction is the same on every terrain, since the height map could not show it. Measured
  before any probe: six wheels lost < 0.2 m of 3.8 m even on sheets of friction 0.01 while six legs lost a third,
  so ice likely favours wheels everywhere: the probe decides.
- `mixed`: the course cut into segments along x, each flat, walls, rubble or a platform (a box up and down),
  with its own difficulty: which obstacle comes first, and how hard, decides.

Gaps cannot be built: the ground is an infinite plane, so a gap needs a raised course the robot must first
climb, which is a `steps` terrain with a trench; no family fakes one. Each family is a pure function of its seed
and settings (`generate`); `perturb` moves every box by at most `shift` in the plane (issue 46, item 4).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from robocompose.io.errors import InputError
from robocompose.modular.terrain import Terrain, TerrainConfig, poisson_disk

Boxes = tuple[np.ndarray, np.ndarray, np.ndarray]  # centres (N, 2), half-sides (N, 2), heights (N,)
SHEET_HEIGHT = 0.005  # m, an ice sheet: visible in the height map, lower than anything a module trips on
PERTURB_STREAM = 4602  # rng stream of `perturb`, apart from every generator's


def _check_range(config: object, name: str, low: float = 0.0, closed: bool = True) -> None:
    """`config.name` a pair [lo, hi] of finite numbers, lo <= hi, lo >= low (> low unless closed); else
    InputError naming the field, the value and the expectation."""
    value = getattr(config, name)
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise InputError(f"{name}: expected [low, high], found {value!r}")
    lo, hi = (float(v) for v in value)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi and (lo >= low if closed else lo > low)):
        bound = "" if low == -math.inf else f", low {'>=' if closed else '>'} {low:g}"
        raise InputError(f"{name}: expected finite [low, high] with low <= high{bound}, found {list(value)}")
    object.__setattr__(config, name, (lo, hi))  # YAML gives lists; a frozen config keeps tuples


def _check_number(config: object, name: str, low: float, high: float = math.inf, closed: bool = True) -> None:
    value = getattr(config, name)
    ok = isinstance(value, (int, float)) and math.isfinite(value) and (value >= low if closed else value > low)
    if not (ok and value <= high):
        bounds = f"{'>=' if closed else '>'} {low:g}" + (f" and <= {high:g}" if math.isfinite(high) else "")
        raise InputError(f"{name}: expected a finite number {bounds}, found {value!r}")


@dataclass(frozen=True)
class Course:
    """Fields every family shares: the course (the block world's default profile) and frictions."""

    x_range: tuple[float, float] = (-1.0, 5.0)  # m, course extent along x (the default profile's)
    y_range: tuple[float, float] = (-2.0, 2.0)  # m, course extent along y; full-width obstacles span it
    clear_x: float = 0.5  # m, no obstacle within |x| < clear_x (the robot starts at the origin)
    friction: float = 0.7  # lateral friction of every box (the block world's block friction)
    ground_friction: float = 0.8  # lateral friction of the ground plane (the block world's)

    def __post_init__(self) -> None:
        for name in ("x_range", "y_range"):
            _check_range(self, name, low=-math.inf)
            lo, hi = getattr(self, name)
            if not lo < hi:
                raise InputError(f"{name}: expected [low, high] with low < high (m), found {[lo, hi]}")
        _check_number(self, "clear_x", 0.0)
        if self.clear_x >= self.x_range[1]:
            raise InputError(f"clear_x: expected < x_range's end {self.x_range[1]:g} m, found {self.clear_x!r}")
        _check_number(self, "friction", 0.0, closed=False)
        _check_number(self, "ground_friction", 0.0, closed=False)

    def terrain_config(self) -> TerrainConfig:
        """The block world's config carrying this course and its frictions: what `add_terrain` and `height_map`
        read from a Terrain (the block generator's own ranges stay at their defaults and are unused)."""
        return TerrainConfig(x_range=self.x_range, y_range=self.y_range, clear_x=self.clear_x,
                             friction=self.friction, ground_friction=self.ground_friction)


@dataclass(frozen=True)
class WallsConfig(Course):
    """Full-width walls across the course."""

    # m, H per terrain: from a kerb to above a wheel's radius (measured on one terrain: at 5 cm every design passes,
    # at 7-11 cm some do and some do not, at 13 cm none of five tried did)
    height_range: tuple[float, float] = (0.02, 0.14)
    spread: float = 0.25  # each wall is H * U(1 - spread, 1) tall: walls of one terrain are alike
    spacing_range: tuple[float, float] = (0.6, 1.5)  # m, from one wall's back face to the next one's front, per wall
    thickness_range: tuple[float, float] = (0.05, 0.30)  # m, a wall's depth along x, per wall

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_range(self, "height_range")
        _check_number(self, "spread", 0.0, 1.0)
        _check_range(self, "spacing_range", closed=False)
        _check_range(self, "thickness_range", closed=False)


@dataclass(frozen=True)
class StepsConfig(Course):
    """A staircase up to a plateau."""

    riser_range: tuple[float, float] = (0.01, 0.12)  # m, R per terrain (every riser of a terrain is R)
    tread_range: tuple[float, float] = (0.1, 1.0)  # m, T per terrain (every tread of a terrain is T)
    first_range: tuple[float, float] = (0.0, 0.5)  # m, the first riser at clear_x + U(first_range)
    steps: int = 10  # risers; after the last, a plateau to the course's end

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_range(self, "riser_range")
        _check_range(self, "tread_range", closed=False)
        _check_range(self, "first_range")
        if not isinstance(self.steps, int) or self.steps < 1:
            raise InputError(f"steps: expected a positive integer (risers), found {self.steps!r}")


@dataclass(frozen=True)
class RubbleConfig(Course):
    """A dense field of small boxes."""

    height_range: tuple[float, float] = (0.0, 0.15)  # m, H per terrain; box heights U(0, H)
    spacing_range: tuple[float, float] = (0.2, 0.4)  # m, Poisson-disk minimum distance between centres, per terrain
    side_range: tuple[float, float] = (0.02, 0.08)  # m, box half-sides in x and y, per box
    candidates: int = 30  # Bridson's k

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_range(self, "height_range")
        _check_range(self, "spacing_range", closed=False)
        _check_range(self, "side_range", closed=False)
        if not isinstance(self.candidates, int) or self.candidates < 1:
            raise InputError(f"candidates: expected a positive integer, found {self.candidates!r}")


@dataclass(frozen=True)
class IceConfig(Course):
    """Low-friction sheets across the course."""

    friction: float = 0.1  # the sheets' lateral friction (the boxes' friction; the ground keeps 0.8)
    coverage_range: tuple[float, float] = (0.0, 1.0)  # share of segments iced, drawn per terrain
    segment_range: tuple[float, float] = (0.3, 1.0)  # m, length along x of each segment, per segment

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_range(self, "coverage_range")
        if self.coverage_range[1] > 1:
            raise InputError(f"coverage_range: expected shares within [0, 1], found {list(self.coverage_range)}")
        _check_range(self, "segment_range", closed=False)


MIXED_KINDS = ("flat", "walls", "rubble", "platform")


@dataclass(frozen=True)
class MixedConfig(Course):
    """Segments along the course, each of one kind (`MIXED_KINDS`) and its own difficulty."""

    segment_range: tuple[float, float] = (1.0, 2.0)  # m, length along x of each segment
    height_range: tuple[float, float] = (0.02, 0.14)  # m, a segment's H (walls' and platform's height, rubble's max)
    wall_spacing_range: tuple[float, float] = (0.6, 1.5)  # m, as WallsConfig.spacing_range
    wall_thickness_range: tuple[float, float] = (0.05, 0.30)  # m, as WallsConfig.thickness_range
    rubble_spacing_range: tuple[float, float] = (0.2, 0.4)  # m, as RubbleConfig.spacing_range
    rubble_side_range: tuple[float, float] = (0.02, 0.08)  # m, as RubbleConfig.side_range

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_range(self, "segment_range", closed=False)
        _check_range(self, "height_range")
        for name in ("wall_spacing_range", "wall_thickness_range", "rubble_spacing_range", "rubble_side_range"):
            _check_range(self, name, closed=False)


def _walls(rng: np.random.Generator, x0: float, x1: float, width: tuple[float, float], height: float,
           spread: float, spacing: tuple[float, float], thickness: tuple[float, float]) -> Boxes:
    """Full-width walls from x0 (the first one's front face) until x1; heights height * U(1 - spread, 1)."""
    centres, sides, heights = [], [], []
    y0, y1 = width
    front = x0
    while True:
        depth = rng.uniform(*thickness)
        if front + depth > x1:
            break
        centres.append((front + depth / 2, (y0 + y1) / 2))
        sides.append((depth / 2, (y1 - y0) / 2))
        heights.append(height * rng.uniform(1 - spread, 1))
        front += depth + rng.uniform(*spacing)
    return _boxes(centres, sides, heights)


def _rubble(rng: np.random.Generator, x0: float, x1: float, width: tuple[float, float], height: float,
            spacing: float, side: tuple[float, float], candidates: int) -> Boxes:
    """Poisson-disk boxes lying within [x0, x1] x width (centres kept a largest half-side inside), half-sides
    U(side), heights U(0, height)."""
    inset = side[1]
    if x1 - x0 <= 2 * inset:
        return _boxes([], [], [])
    centres = poisson_disk(rng, (x0 + inset, x1 - inset), (width[0] + inset, width[1] - inset), spacing, candidates)
    sides = rng.uniform(*side, size=(len(centres), 2))
    return centres, sides, rng.uniform(0.0, height, size=len(centres))


def _boxes(centres: list, sides: list, heights: list) -> Boxes:
    return (np.array(centres, dtype=np.float64).reshape(-1, 2), np.array(sides, dtype=np.float64).reshape(-1, 2),
            np.array(heights, dtype=np.float64))


def _join(parts: list[Boxes]) -> Boxes:
    return tuple(np.concatenate([p[i] for p in parts]) if parts else _boxes([], [], [])[i] for i in range(3))


def walls(rng: np.random.Generator, config: WallsConfig) -> Boxes:
    height = rng.uniform(*config.height_range)
    return _walls(rng, config.clear_x, config.x_range[1], config.y_range, height, config.spread,
                  config.spacing_range, config.thickness_range)


def steps(rng: np.random.Generator, config: StepsConfig) -> Boxes:
    """Step i (0-based) is one box from its riser to the course's end, (i + 1) R tall: the boxes overlap, and the
    tallest one under a point is the surface there (a plateau after the last riser)."""
    riser, tread = rng.uniform(*config.riser_range), rng.uniform(*config.tread_range)
    front = config.clear_x + rng.uniform(*config.first_range)
    end = config.x_range[1]
    y0, y1 = config.y_range
    centres, sides, heights = [], [], []
    for i in range(config.steps):
        x = front + i * tread
        if x >= end:
            break
        centres.append(((x + end) / 2, (y0 + y1) / 2))
        sides.append(((end - x) / 2, (y1 - y0) / 2))
        heights.append((i + 1) * riser)
    return _boxes(centres, sides, heights)


def rubble(rng: np.random.Generator, config: RubbleConfig) -> Boxes:
    height, spacing = rng.uniform(*config.height_range), rng.uniform(*config.spacing_range)
    return _rubble(rng, config.clear_x, config.x_range[1], config.y_range, height, spacing, config.side_range,
                   config.candidates)


def ice(rng: np.random.Generator, config: IceConfig) -> Boxes:
    coverage = rng.uniform(*config.coverage_range)
    y0, y1 = config.y_range
    centres, sides, heights = [], [], []
    x = config.clear_x
    while x < config.x_range[1]:
        length = min(rng.uniform(*config.segment_range), config.x_range[1] - x)
        if rng.uniform() < coverage:
            centres.append((x + length / 2, (y0 + y1) / 2))
            sides.append((length / 2, (y1 - y0) / 2))
            heights.append(SHEET_HEIGHT)
        x += length
    return _boxes(centres, sides, heights)


def mixed(rng: np.random.Generator, config: MixedConfig) -> Boxes:
    """Segments from clear_x to the course's end; a platform is one full-width box over its segment's middle
    half (up, then down)."""
    parts = []
    x = config.clear_x
    while x < config.x_range[1]:
        x1 = min(x + rng.uniform(*config.segment_range), config.x_range[1])
        kind = MIXED_KINDS[int(rng.integers(len(MIXED_KINDS)))]
        height = rng.uniform(*config.height_range)
        if kind == "walls":
            parts.append(_walls(rng, x, x1, config.y_range, height, 0.25, config.wall_spacing_range,
                                config.wall_thickness_range))
        elif kind == "rubble":
            parts.append(_rubble(rng, x, x1, config.y_range, height, rng.uniform(*config.rubble_spacing_range),
                                 config.rubble_side_range, 30))
        elif kind == "platform":
            y0, y1 = config.y_range
            parts.append(_boxes([((x + x1) / 2, (y0 + y1) / 2)], [((x1 - x) / 4, (y1 - y0) / 2)], [height]))
        x = x1
    return _join(parts)


@dataclass(frozen=True)
class Family:
    """A family's settings class, its generator, and its rng stream (apart from other uses of a seed)."""

    config: type
    generator: Callable[[np.random.Generator, object], Boxes]
    stream: int


# The registry of terrain families: the only list (CLI choices, probes, docs derive from it).
FAMILIES: dict[str, Family] = {
    "walls": Family(WallsConfig, walls, 4610),
    "steps": Family(StepsConfig, steps, 4611),
    "rubble": Family(RubbleConfig, rubble, 4612),
    "ice": Family(IceConfig, ice, 4613),
    "mixed": Family(MixedConfig, mixed, 4614),
}


def family_config(name: str, overrides: Mapping | None = None, where: str = "family settings") -> Course:
    """The settings of family `name`: its defaults with `overrides` (field -> value) applied; InputError naming an
    unknown family, an unknown field, or a bad value."""
    if name not in FAMILIES:
        raise InputError(f"family: unknown family {name!r}; expected one of {sorted(FAMILIES)}")
    from robocompose.params import build_config

    return build_config(FAMILIES[name].config, dict(overrides or {}), f"{where}: {name}")


def generate(name: str, seed: int, config: Course | None = None) -> Terrain:
    """The terrain of family `name` and `seed` (a pure function of both and the settings)."""
    config = family_config(name) if config is None else config
    family = FAMILIES.get(name)
    if family is None or not isinstance(config, family.config):
        raise InputError(f"family: expected settings of {name!r} ({family and family.config.__name__}), "
                         f"found {type(config).__name__}")
    centres, sides, heights = family.generator(np.random.default_rng([int(seed), family.stream]), config)
    return Terrain(int(seed), centres, sides, heights, config.terrain_config())


def perturb(terrain: Terrain, index: int, shift: float) -> Terrain:
    """Perturbation `index` of `terrain`: every box's centre moved by a point drawn uniformly in a disc of radius
    `shift` (m); sizes, heights and count kept. Seeded by the terrain's seed and `index`, so it is reproducible."""
    if not (math.isfinite(shift) and shift >= 0):
        raise InputError(f"shift: expected a finite distance >= 0 (m), found {shift!r}")
    rng = np.random.default_rng([int(terrain.seed), int(index), PERTURB_STREAM])
    n = len(terrain.centers)
    radius, angle = shift * np.sqrt(rng.uniform(size=n)), rng.uniform(0, 2 * math.pi, size=n)
    moved = terrain.centers + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    return dataclasses.replace(terrain, centers=moved)
