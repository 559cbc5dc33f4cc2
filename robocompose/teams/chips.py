"""Terrain chips: DroneDeploy label PNGs -> class ids -> the four terrains; a synthetic chip generator.

The DroneDeploy segmentation benchmark (dronedeploy/dd-ml-segmentation-benchmark, libs/config.py)
labels scenes with one RGB colour per class; its README lists them in BGR order. Class ids follow its
LABELS list: 0 BUILDING, 1 CLUTTER, 2 VEGETATION, 3 WATER, 4 GROUND, 5 CAR; magenta is IGNORE.
As in its images2chips.py, scenes are cut into 300 x 300 chips at stride 300 and a chip holding any
IGNORE pixel is skipped.

Class -> terrain (our choice; the thesis does not give one):
    WATER -> Water;  VEGETATION -> Mountain (hills are the vegetated, rough ground);
    GROUND -> Plain;  BUILDING, CLUTTER, CAR -> City.

The dataset cannot be downloaded here, so `generate_chip` draws label maps with the same classes and
colours (rivers and lakes, vegetated hills, fields, city blocks with cars) and `write_label_png`
stores them in the benchmark's PNG format, so the loader reads both the same way.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np
from PIL import Image
from scipy import ndimage

from robocompose.io.errors import InputError, check_field

CLASSES: tuple[str, ...] = ("BUILDING", "CLUTTER", "VEGETATION", "WATER", "GROUND", "CAR")
BUILDING, CLUTTER, VEGETATION, WATER, GROUND, CAR = range(6)
CLASS_COLOURS_RGB: tuple[tuple[int, int, int], ...] = (
    (230, 25, 75), (145, 30, 180), (60, 180, 75), (245, 130, 48), (255, 255, 255), (0, 130, 200),
)
IGNORE_COLOUR_RGB = (255, 0, 255)
CLASS_TO_TERRAIN = np.array([3, 3, 1, 0, 2, 3], dtype=np.uint8)  # indexed by class id -> terrain id
CHIP_SIZE = 300


def _colour_code(rgb: np.ndarray) -> np.ndarray:
    rgb = rgb.astype(np.int64)
    return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]


_CLASS_CODES = _colour_code(np.array(CLASS_COLOURS_RGB))
_IGNORE_CODE = int(_colour_code(np.array(IGNORE_COLOUR_RGB)))


@dataclass(frozen=True)
class ChipsConfig:
    directory: str = ""  # DroneDeploy label PNGs to cut into chips; "" = generate synthetic chips
    n_synthetic: int = 24  # synthetic chips to generate
    seed: int = 0  # seed of the synthetic chips
    max_chips: int = 0  # keep the first max_chips chips (sorted by id); 0 = all

    def __post_init__(self) -> None:
        check_field(self.n_synthetic >= 1, "n_synthetic", "an integer >= 1", self.n_synthetic)
        check_field(self.seed >= 0, "seed", "an integer >= 0", self.seed)
        check_field(self.max_chips >= 0, "max_chips", "an integer >= 0 (0 = all)", self.max_chips)


@dataclass(frozen=True)
class Chip:
    chip_id: str
    source: str  # the label PNG it was cut from
    classes: np.ndarray  # (H, W) uint8 class ids

    @functools.cached_property  # read by the decomposition, the features and the raster of every query
    def terrain(self) -> np.ndarray:
        """(H, W) uint8 terrain ids (0 Water, 1 Mountain, 2 Plain, 3 City)."""
        return CLASS_TO_TERRAIN[self.classes]


# Pixels of a label image that are decoded at most: 12k x 12k, above the largest DroneDeploy scene; PIL refuses more
# than twice its own limit (179M) as a decompression bomb, and a 15k x 15k PNG of one colour is only ~0.2 MB.
MAX_LABEL_PIXELS = 12_000 * 12_000


def read_label_png(path: Path | BinaryIO, name: str | None = None,
                   max_pixels: int = MAX_LABEL_PIXELS) -> tuple[np.ndarray, np.ndarray]:
    """Read one label PNG (a file, or an open binary stream named `name` in errors); return (classes (H, W) uint8,
    ignore mask (H, W) bool).

    Fails with the file and the offending colour if a pixel has a colour that is not in the table, and before
    decoding an image of more than `max_pixels` pixels.
    """
    import warnings

    name = str(path) if name is None else name
    too_big = f"{name}: more than {max_pixels:,} pixels, expected a DroneDeploy label PNG of at most that many"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # the size is checked below
            image = Image.open(path)
        with image:
            if image.format != "PNG":
                raise InputError(f"{name}: a {image.format} image, expected a DroneDeploy label PNG")
            if image.width * image.height > max_pixels:
                raise InputError(f"{too_big} (found {image.width} x {image.height})")
            rgb = np.asarray(image.convert("RGB"))
    except Image.DecompressionBombError:
        raise InputError(too_big) from None
    except InputError:
        raise
    except (OSError, ValueError) as err:  # PIL: UnidentifiedImageError (an OSError), truncated or bad data
        raise InputError(f"{name}: not a readable image, expected a DroneDeploy label PNG ({err})") from None
    codes = _colour_code(rgb)  # (H, W)
    ignore = codes == _IGNORE_CODE
    order = np.argsort(_CLASS_CODES)
    position = np.clip(np.searchsorted(_CLASS_CODES[order], codes), 0, len(order) - 1)
    classes = order[position]
    unknown = (_CLASS_CODES[classes] != codes) & ~ignore
    if unknown.any():
        row, col = np.argwhere(unknown)[0]
        colour = tuple(int(v) for v in rgb[row, col])
        raise InputError(f"{name}: pixel (row {row}, col {col}) has colour {colour}, "
                         f"expected one of the DroneDeploy label colours {CLASS_COLOURS_RGB} "
                         f"or IGNORE {IGNORE_COLOUR_RGB}")
    return classes.astype(np.uint8), ignore


def chips_in_file(path: Path | BinaryIO, chip_size: int = CHIP_SIZE, name: str | None = None,
                  max_pixels: int = MAX_LABEL_PIXELS, stem: str | None = None) -> Iterator[Chip]:
    """Yield the chips of one label PNG (a file, or a binary stream named `name` in errors): chip_size x chip_size
    windows at stride chip_size (row-major), skipping windows that hold any IGNORE pixel. Chip ids are "<stem>-<window
    index, 6 digits>", the stem of the file's name unless `stem` is given."""
    name = str(path) if name is None else name
    stem = Path(name).stem if stem is None else stem
    classes, ignore = read_label_png(path, name, max_pixels)
    height, width = classes.shape
    window = 0
    for top in range(0, height - chip_size + 1, chip_size):
        for left in range(0, width - chip_size + 1, chip_size):
            rows, cols = slice(top, top + chip_size), slice(left, left + chip_size)
            if not ignore[rows, cols].any():
                yield Chip(f"{stem}-{window:06d}", name, classes[rows, cols].copy())
            window += 1


def load_chips(directory: Path, chip_size: int = CHIP_SIZE) -> Iterator[Chip]:
    """Yield the chips of every *.png label file in `directory` (sorted by name), see chips_in_file."""
    if not Path(directory).is_dir():
        raise InputError(f"{directory}: not a directory (teams.chips.directory: expected a folder of label PNGs)")
    files = sorted(Path(directory).glob("*.png"))
    if not files:
        raise InputError(f"{directory}: no *.png label files (teams.chips.directory)")
    for path in files:
        yield from chips_in_file(path, chip_size)


def label_png_bytes(classes: np.ndarray) -> bytes:
    """(H, W) class ids as an RGB label PNG in the benchmark's colours."""
    import io

    buffer = io.BytesIO()
    Image.fromarray(np.array(CLASS_COLOURS_RGB, dtype=np.uint8)[classes], mode="RGB").save(buffer, format="PNG")
    return buffer.getvalue()


def write_label_png(classes: np.ndarray, path: Path) -> None:
    """Write (H, W) class ids as an RGB label PNG in the benchmark's colours."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_bytes(label_png_bytes(classes))


def _smooth_noise(rng: np.random.Generator, size: int, scale: float) -> np.ndarray:
    """(size, size) Gaussian-smoothed noise with features of about `scale` pixels, standardised."""
    field = ndimage.gaussian_filter(rng.standard_normal((size, size)), sigma=scale, mode="wrap")
    return (field - field.mean()) / field.std()


def _river(rng: np.random.Generator, size: int) -> np.ndarray:
    """(size, size) bool: a meandering band 8-24 px wide crossing the chip."""
    t = np.linspace(0.0, 1.0, size)
    centre = size * (rng.uniform(0.2, 0.8) + 0.12 * np.sin(2 * np.pi * (rng.uniform(0.5, 1.5) * t
                                                                         + rng.uniform())))
    half_width = rng.uniform(4.0, 12.0)
    across = np.arange(size)[None, :]
    band = np.abs(across - centre[:, None]) < half_width  # river runs top to bottom
    return band if rng.random() < 0.5 else band.T


def _city(rng: np.random.Generator, size: int, area: np.ndarray) -> np.ndarray:
    """(size, size) class ids for a city grid inside `area`: blocks of buildings, clutter, cars."""
    city = np.empty((size, size), dtype=np.uint8)
    block = int(rng.integers(30, 55))
    road = int(rng.integers(5, 9))
    for top in range(0, size, block):
        for left in range(0, size, block):
            inner = (slice(top + road, top + block), slice(left + road, left + block))
            city[inner] = rng.choice([BUILDING, CLUTTER, VEGETATION], p=[0.65, 0.15, 0.2])
            city[top:top + road, left:left + block] = GROUND  # streets
            city[top:top + block, left:left + road] = GROUND
    cars = rng.random((size, size)) < 0.002
    city[ndimage.binary_dilation(cars, iterations=2) & (city == GROUND)] = CAR
    return np.where(area, city, 255).astype(np.uint8)


def generate_chip(rng: np.random.Generator, size: int = CHIP_SIZE) -> np.ndarray:
    """Draw one (size, size) uint8 class map: fields with vegetated hills, maybe a city, river, lakes.

    Which features appear and how much of the chip they take is drawn per chip, so chips range from
    open farmland to dense town and water-dominated land.
    """
    classes = np.full((size, size), GROUND, dtype=np.uint8)
    hills = _smooth_noise(rng, size, scale=size / 10) > rng.uniform(0.0, 1.4)
    classes[hills] = VEGETATION
    hedges = (np.abs(_smooth_noise(rng, size, scale=size / 25)) < 0.05) & (rng.random() < 0.6)
    classes[hedges] = VEGETATION
    if rng.random() < 0.5:
        city_area = _smooth_noise(rng, size, scale=size / 6) > rng.uniform(-0.3, 1.0)
        city = _city(rng, size, city_area)
        classes = np.where(city_area, city, classes)
    if rng.random() < 0.6:
        classes[_river(rng, size)] = WATER
    if rng.random() < 0.4:
        lakes = _smooth_noise(rng, size, scale=size / 12) > rng.uniform(0.8, 1.8)
        classes[lakes] = WATER
    return classes


def synthetic_chip(seed: int, index: int = 0, size: int = CHIP_SIZE) -> Chip:
    """Chip `index` of the synthetic set `seed`, as write_synthetic_chips + load_chips would give it."""
    classes = generate_chip(np.random.default_rng([seed, index]), size)
    return Chip(f"synthetic-{seed}-{index:05d}-000000", "generated", classes)


def write_synthetic_chips(directory: Path, n_chips: int, seed: int, size: int = CHIP_SIZE) -> list[Path]:
    """Generate `n_chips` label PNGs "synthetic-<seed>-<index>.png" in `directory`; return their paths.

    Chip i is drawn from numpy Generator((seed, i)), so each chip is fixed by (seed, index).
    """
    paths = []
    for index in range(n_chips):
        rng = np.random.default_rng([seed, index])
        path = Path(directory) / f"synthetic-{seed}-{index:05d}.png"
        write_label_png(generate_chip(rng, size), path)
        paths.append(path)
    return paths


def prepare_chips(config: ChipsConfig, store: Path) -> list[Chip]:
    """Fill `store` with one label PNG per chip and return the chips (sorted by id).

    Synthetic chips (config.directory empty) are generated into `store` and read back with the
    loader; DroneDeploy label PNGs in config.directory are cut into chips, each written to
    `store/<chip id>.png`. A chip's `source` is its file in `store`.
    """
    # Every source file is read (and checked) before the store is touched, so bad input leaves it as it was.
    source = sorted(load_chips(Path(config.directory)), key=lambda chip: chip.chip_id) if config.directory else []
    store = Path(store)
    store.mkdir(parents=True, exist_ok=True)
    for stale in store.glob("*.png"):
        stale.unlink()
    if not config.directory:
        write_synthetic_chips(store, config.n_synthetic, config.seed)
        chips = sorted(load_chips(store), key=lambda chip: chip.chip_id)
    else:
        chips = []
        for chip in source:
            write_label_png(chip.classes, store / f"{chip.chip_id}.png")
            chips.append(Chip(chip.chip_id, str(store / f"{chip.chip_id}.png"), chip.classes))
    return chips[:config.max_chips] if config.max_chips else chips


def read_chip(chip_id: str, source: str | Path) -> Chip:
    """The chip stored as one label PNG at `source` (as written by prepare_chips)."""
    classes, ignore = read_label_png(Path(source))
    if ignore.any():
        raise InputError(f"{source}: chip {chip_id} holds IGNORE pixels")
    return Chip(chip_id, str(source), classes)
