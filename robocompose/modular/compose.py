"""`robocompose compose modular`: the k best distinct designs for a terrain from a trained EG-GAN generator.

    robocompose compose modular --terrain-seed 1000 --k 10 [--max leg=2,wheel=0] [--model PATH] [--simulate]
    robocompose compose modular --heightmap map.npy ...

Prints one JSON object: `designs` (each: `design`, the port string `modular evaluate` takes, and `score`, the
generator's probability of it for this terrain), ranked without simulating; `--simulate` adds each design's
distance and status. `--min-hamming 2` asks for a diverse answer: designs pairwise at Hamming distance >= 2,
taken in probability order (`robocompose.modular.diverse`; `found` says when fewer than `--k` are that far
apart). Designs the fitness rule rejects and designs over a `--max` cap are never answered. With no `--model`,
the generator shipped in the repository (trained by the default profile) is used.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from robocompose.arguments import input_file, int_between, non_negative_int, positive_int
from robocompose.io.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from robocompose.eggan.networks import Generator
    from robocompose.modular.params import ModularParams
    from robocompose.modular.plugins.eggan_problem import ModularEgganProblem
    from robocompose.modular.terrain import TerrainConfig

SHIPPED_MODEL = Path(__file__).resolve().parent / "pretrained" / "eggan.pt"
# generator draws per query at most: doubled up to 16x, 1.6 million draws of ~1 kB each (about 2 GB at the peak)
MAX_SAMPLES = 100_000
MODULE_NAMES = {"none": "n", "leg": "l", "wheel": "w", "legwheel": "b", "leg-wheel": "b", "leg_wheel": "b"}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add `compose modular` to the `compose` command."""
    modular = subparsers.add_parser("modular", help="modular robot designs for a terrain in milliseconds (EG-GAN)")
    task = modular.add_mutually_exclusive_group(required=True)
    task.add_argument("--terrain-seed", type=non_negative_int, help="seed of a block terrain")
    task.add_argument("--heightmap", type=Path, help="a .npy height map of shape (50, 20), metres, x by y, heights "
                      "within the params' block heights (modular.eval.terrain.max_height_range)")
    modular.add_argument("--k", type=positive_int, default=10, help="distinct designs to answer (default 10)")
    modular.add_argument("--max", default="", help="caps per module type, e.g. leg=2,wheel=0 (none, leg, wheel, "
                         "legwheel)")
    modular.add_argument("--model", type=input_file("an EG-GAN generator file"),
                         help=f"generator file (default: the shipped {SHIPPED_MODEL.name})")
    modular.add_argument("--samples", type=int_between(1, MAX_SAMPLES, "doubled up to 16x: about 2 GB at most"),
                         default=64, help="generator draws per query, doubled up to 16x while fewer than --k designs "
                         f"are found (default 64, at most {MAX_SAMPLES:,})")
    modular.add_argument("--seed", type=non_negative_int, default=0, help="seed of the noise vectors")
    modular.add_argument("--min-hamming", type=int, default=1, help="answer designs pairwise at Hamming distance >= "
                         "this many ports, taken in probability order (default 1: distinct designs; 2..6: a diverse "
                         "answer, fewer than --k designs if the draws hold too few that far apart)")
    modular.add_argument("--simulate", action="store_true", help="also simulate each design (distance, status)")
    modular.add_argument("--params", type=Path, default=None, help="params file with a modular: section (default: "
                         "params.yaml if there is one, else the defaults); a file named here must exist")
    modular.set_defaults(handler=_compose)

    ship = subparsers.add_parser("ship-modular", help="copy a trained generator (float16) to the shipped default")
    ship.add_argument("--from", dest="source", type=input_file("an EG-GAN generator file"),
                      default=Path("models/eggan_modular_crowding.pt"),
                      help="generator of `dvc repro train_eggan_modular` (default: the EG-GAN-crowding one)")
    ship.set_defaults(handler=_ship)


def parse_caps(text: str, label: str = "--max") -> dict[str, int]:
    """'leg=2,wheel=0' -> {'l': 2, 'w': 0}; a clear error naming `label` (the flag or field) otherwise."""
    caps: dict[str, int] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        name, _, value = part.partition("=")
        if name.strip().lower() not in MODULE_NAMES or not value.strip().isdigit():
            raise InputError(f"{label} {text!r}: expected NAME=COUNT pairs with NAME in "
                             f"{sorted(set(MODULE_NAMES) - {'leg-wheel', 'leg_wheel'})} and COUNT >= 0")
        caps[MODULE_NAMES[name.strip().lower()]] = int(value)
    return caps


def read_heightmap(path: Path, terrain: TerrainConfig, where: str) -> np.ndarray:
    """A (50, 20) float32 height map from a .npy file (see `check_heightmap`); `where` names the params."""
    if not path.is_file():
        found = "a directory" if path.is_dir() else "no such file"
        raise InputError(f"--heightmap {path}: {found}, expected a .npy height map")
    return check_heightmap(load_npy(path.read_bytes(), f"--heightmap {path}"), terrain, where, f"--heightmap {path}")


def load_npy(data: bytes, label: str) -> np.ndarray:
    """The array of .npy bytes (numpy.save format); never unpickled. `label` names the input in the error."""
    import io

    import numpy as np

    try:
        array = np.load(io.BytesIO(data), allow_pickle=False)
    except (OSError, ValueError, EOFError):  # pickled, text, truncated: np.load's reasons say little to a user
        raise InputError(f"{label}: not a .npy array file (numpy.save format)") from None
    if not isinstance(array, np.ndarray):  # an .npz archive
        raise InputError(f"{label}: a .npz archive, expected a .npy array file (numpy.save format)")
    return array


def check_heightmap(heights: np.ndarray, terrain: TerrainConfig, where: str, label: str) -> np.ndarray:
    """`heights` as (50, 20) float32, checked to be a height map of the block terrains of `terrain`.

    The generator learnt height maps of blocks of height U(0, H), H ~ U(max_height_range), on the ground (height 0):
    a map outside [0, max_height_range[1]] is no terrain of the model. `where` names the params the range is from,
    `label` the input (a flag and file, or a request field).
    """
    import numpy as np

    from robocompose.modular.terrain import GRID_X, GRID_Y

    if heights.shape != (GRID_X, GRID_Y):
        raise InputError(f"{label}: expected shape ({GRID_X}, {GRID_Y}) (x by y), found {heights.shape}")
    if not (np.issubdtype(heights.dtype, np.integer) or np.issubdtype(heights.dtype, np.floating)):
        raise InputError(f"{label}: expected real numbers (metres), found dtype {heights.dtype}")
    if not np.isfinite(heights).all():
        bad = heights[~np.isfinite(heights)][0]
        raise InputError(f"{label}: expected finite numbers (metres), found {bad}")
    low, high = 0.0, terrain.max_height_range[1]
    if heights.min() < low or heights.max() > high:
        raise InputError(f"{label}: heights expected in [{low:g}, {high:g}] m (the ground and the highest "
                         f"block of {where}.terrain.max_height_range), found [{heights.min():g}, {heights.max():g}]")
    return heights.astype(np.float32)


def _ship(args: argparse.Namespace) -> None:
    from robocompose.eggan.query import load_generator, save_generator
    from robocompose.modular.evaluate import EvalSettings, FitnessRule
    from robocompose.modular.params import ExperimentsConfig, ModularParams
    from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem

    problem = ModularEgganProblem(ModularParams(EvalSettings(), FitnessRule(), ExperimentsConfig()), FitnessConfig())
    generator, info = load_generator(args.source, problem)
    meta = {k: v for k, v in info.items() if k not in ("problem", "task_shape", "design_shape", "network",
                                                         "model_code", "weights")}
    save_generator(generator, problem, SHIPPED_MODEL, {**meta, "shipped_from": str(args.source)}, half=True)
    print(json.dumps({"shipped": str(SHIPPED_MODEL), "from": str(args.source), "bytes": SHIPPED_MODEL.stat().st_size}))


DISTANCES = ("table", "rollout")  # where a query's distances come from: the committed exhaustive table, pybullet


@dataclass
class ModularComposer:
    """A trained generator kept warm with the params it answers for: `query` is what `compose modular` prints and
    what the service (robocompose.serve) answers, one function for both."""

    path: Path
    params: ModularParams
    problem: ModularEgganProblem
    generator: Generator
    info: dict

    @classmethod
    def load(cls, path: Path | None, params: ModularParams) -> ModularComposer:
        """The generator at `path` (default: the shipped one) for the modular problem of `params`."""
        from robocompose.eggan.query import load_generator
        from robocompose.modular.plugins.eggan_problem import FitnessConfig, ModularEgganProblem

        path = Path(path or SHIPPED_MODEL)
        problem = ModularEgganProblem(params, FitnessConfig())
        generator, info = load_generator(path, problem)
        from robocompose.modular.truth import physics_digest

        physics_digest()  # the code digest, parsed once now: ast.parse in concurrent threads is not safe
        return cls(path, params, problem, generator, info)

    def query(self, terrain_seed: int | None = None, heights: np.ndarray | None = None, k: int = 10,
              caps: dict[str, int] | None = None, samples: int = 64, seed: int = 0,
              distances: str | None = None, min_hamming: int = 1) -> dict:
        """The k most probable distinct designs for a terrain (its seed, or a checked (50, 20) height map) that the
        fitness rule accepts and `caps` allows, each with its score; `distances` adds each design's distance from
        the terrain's committed exhaustive table ("table") or a pybullet rollout ("rollout"), both by seed only.
        `min_hamming` > 1: the designs are pairwise at least that many ports apart, taken in probability order
        (`robocompose.modular.diverse.diverse_distinct`; fewer than k if the draws hold too few)."""
        import torch

        from robocompose.eggan.query import top_distinct
        from robocompose.modular.diverse import check_min_hamming, diverse_distinct

        if (terrain_seed is None) == (heights is None):
            raise InputError("terrain: expected a terrain seed or a height map, exactly one")
        if distances is not None and distances not in DISTANCES:
            raise InputError(f"distances: expected one of {list(DISTANCES)}, found {distances!r}")
        if distances is not None and terrain_seed is None:
            raise InputError(f"distances: {distances!r} needs a terrain seed (a height map alone does not define the "
                             "blocks)")
        check_min_hamming(min_hamming, "min_hamming")
        caps = caps or {}
        table = self._table(terrain_seed) if distances == "table" else None
        started = time.perf_counter()
        tensor = self.problem.encode_task(terrain_seed) if heights is None else torch.from_numpy(heights)

        def keep(d: str) -> bool:
            return not self.params.fitness.skips(d) and all(d.count(m) <= c for m, c in caps.items())

        ranked = top_distinct(self.generator, self.problem, terrain_seed, k, samples, seed, tensor, keep=keep) \
            if min_hamming == 1 else diverse_distinct(self.generator, self.problem, terrain_seed, k, samples,
                                                      min_hamming, seed, tensor, keep=keep)
        query_ms = (time.perf_counter() - started) * 1000
        designs = [{"design": r.design, "score": round(r.score, 6)} for r in ranked]
        if distances == "rollout":
            from robocompose.modular.evaluate import evaluate_designs

            results = evaluate_designs([d["design"] for d in designs], terrain_seed, self.params.eval,
                                       self.params.fitness)
            for entry, result in zip(designs, results, strict=True):
                entry["distance"], entry["status"] = result.distance, result.status
        elif table is not None:
            for entry in designs:
                entry["distance"] = float(table[entry["design"]])
        return {"terrain_seed": terrain_seed, "k": k, "found": len(designs), "min_hamming": min_hamming, "max": caps,
                "designs": designs,
                "distances": distances, "model": str(self.path), "model_run_key": self.info.get("run_key"),
                "query_ms": round(query_ms, 2)}

    def _table(self, terrain_seed: int) -> dict[str, float]:
        """design -> distance of the terrain's committed exhaustive table measured with these params' settings."""
        from robocompose.modular.truth import COMMITTED_DIR, read_committed

        table = read_committed(terrain_seed, self.params.eval, self.params.fitness)
        if table is None:
            seeds = sorted(int(p.stem.removeprefix("blocks-")) for p in COMMITTED_DIR.glob("blocks-*.parquet"))
            raise InputError(f"distances: no committed exhaustive table of terrain seed {terrain_seed} measured with "
                             f"these settings (tables under {COMMITTED_DIR}: seeds {seeds})")
        return dict(zip(table.design, table.distance, strict=True))


def _compose(args: argparse.Namespace) -> None:
    import torch

    from robocompose.modular.cli import _params, params_source
    from robocompose.modular.diverse import check_min_hamming

    caps = parse_caps(args.max)
    check_min_hamming(args.min_hamming, "--min-hamming")
    if args.simulate and args.heightmap is not None:
        raise InputError("--simulate needs --terrain-seed (a height map alone does not define the blocks)")
    params = _params(args.params)
    heights = None if args.heightmap is None else read_heightmap(args.heightmap, params.eval.terrain,
                                                                  f"{params_source(args.params)}.eval")
    torch.set_num_threads(1)
    started = time.perf_counter()
    composer = ModularComposer.load(args.model, params)
    load_ms = (time.perf_counter() - started) * 1000
    answer = composer.query(args.terrain_seed, heights, args.k, caps, args.samples, args.seed,
                            "rollout" if args.simulate else None, args.min_hamming)
    print(json.dumps({**answer, "heightmap": str(args.heightmap) if args.heightmap else None,
                      "load_ms": round(load_ms, 2)}))
