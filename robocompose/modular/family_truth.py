"""Tables of a terrain family (or of the block world under perturbation): a fixed design set on seeded terrains,
measured through the evaluation cache and kept like the block world's committed tables, and the gate on them.

- `World`: what a rollout depends on besides design and terrain seed: the family (a `families.FAMILIES` name, or
  "blocks" for the thesis's block world under the profile's `TerrainConfig`), its settings, the episode settings,
  and the perturbation radius. Rollouts are `evaluate.rollouts` on the family's `Terrain`: the block world's robot,
  controller and episode. Cache key (design, "<family>-<seed>" or "<family>-<seed>~p<i>" for perturbation i,
  `World.settings_hash`, 0): the hash covers the episode, the family's settings and `family_digest()`, the code
  `simulate_world` reaches, so it never meets a "blocks-<seed>" key of the block world.
- Perturbed fitness (issue 46, item 4): with `perturbations` P >= 1 a design's distance is its mean over P
  perturbations of the terrain (every box moved by at most `shift`, 2 cm, `families.perturb`); each perturbation's
  rollout is cached on its own, so P = 4 reuses P = 2's. The block world unperturbed (P = 0) goes through
  `evaluate.evaluate_designs`, its own key and cache rows, and a probe reads its committed tables where they
  match, so its numbers are read, never re-made.
- `probe`: per terrain, a table in the `modular_exhaustive` schema under `measured/modular/families/<name>/`
  (`<family>-<seed>.parquet`) with a JSON record (family, settings, fitness rule, perturbations, design set and the
  digest of the code that made it); a terrain whose table is there with the same record is kept, one half done
  resumes from the cache.
- `design_set`: which designs a probe measures ("balanced", the default; "top"; "all": see `DESIGN_SETS`).
- `gate_directories`: the gate (`gate.gate`) on committed tables, family or block world, with height-map features.
"""

from __future__ import annotations

import itertools
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.fanout.cache import EvaluationCache
from robocompose.fanout.executor import Executor, evaluate_many
from robocompose.io import atomic_write_json, read_table, write_table
from robocompose.io.atomic import read_json
from robocompose.io.errors import ArtifactError, InputError
from robocompose.io.provenance import result_digest, settings_digest
from robocompose.modular.controller import make_controller
from robocompose.modular.evaluate import (
    REWARD_STATUSES,
    EvalSettings,
    FitnessRule,
    Result,
    chunk_size,
    evaluate_designs,
    rollouts,
)
from robocompose.modular.families import FAMILIES, Course, family_config, generate, perturb
from robocompose.modular.gate import GateConfig, GateResult, gate, height_map_features
from robocompose.modular.robot import all_designs, valid_in_original
from robocompose.modular.terrain import Terrain, TerrainConfig, generate_terrain, height_map
from robocompose.modular.truth import COMMITTED_DIR, physics_digest, read_committed, read_record

FAMILY_CODE = ("robocompose.modular.family_truth:simulate_world", "robocompose.modular.robot:valid_in_original")
BLOCKS = "blocks"  # the thesis's block world as a probe target (perturbed or not)
SHIFT = 0.02  # m, the perturbation: block positions +- 2 cm
SEED = 0  # rollouts are deterministic; the cache's seed column
FAMILIES_DIR = Path("measured/modular/families")
POOL_DIR = Path("measured/modular/pool")
# Designs a probe measures. "balanced" (default): the 25 best on the block pool's mean from each composition class
# (the module kinds a design uses; pure legs, wheels or leg-wheels have 4 valid designs each), then the best
# remaining ones on that mean, 400 in all. The pool's 400 best ("top") keep the block test terrains' optimum
# (2.620 of 2.621 m) but hold no legs-only design and 16 leg+wheel ones, the designs a tall obstacle may want;
# "balanced" adds them and keeps that optimum too (2.620). "all": the 1296 valid designs (3.2x the cost).
DESIGN_SETS = ("balanced", "top", "all")
SET_SIZE, CLASS_QUOTA = 400, 25
RECORD_KEYS = ("family", "family_settings", "settings", "fitness", "perturbations", "shift", "design_set", "digest")


def family_digest() -> str:
    """16 hex digits of the code a family's rollout reaches (its generator, the perturbation, `evaluate.rollouts`)."""
    return result_digest(*FAMILY_CODE)


@dataclass(frozen=True)
class World:
    """What a probe's rollouts depend on besides the design and the terrain seed."""

    family: str  # a families.FAMILIES name, or BLOCKS
    config: Course | TerrainConfig  # the family's settings (BLOCKS: the block generator's, settings.terrain)
    settings: EvalSettings  # the episode (its `terrain` is used only by BLOCKS)
    shift: float = SHIFT  # m, radius of a perturbation's box moves

    def terrain(self, seed: int, perturbation: int | None) -> Terrain:
        base = (generate_terrain(seed, self.config) if self.family == BLOCKS
                else generate(self.family, seed, self.config))
        return base if perturbation is None else perturb(base, perturbation, self.shift)

    def task_id(self, seed: int, perturbation: int | None) -> str:
        return f"{self.family}-{int(seed)}" + ("" if perturbation is None else f"~p{int(perturbation)}")

    def settings_hash(self) -> str:
        """16 hex digits of everything a rollout depends on besides design, seed and perturbation index."""
        controller = make_controller(self.settings.controller)
        episode = {k: v for k, v in asdict(self.settings).items() if k != "terrain"}
        return settings_digest({"episode": episode, "physics": self.settings.physics(),
                                "gait": getattr(controller, "gait", None), "controller": type(controller).__name__,
                                "family": self.family, "family_settings": asdict(self.config), "shift": self.shift,
                                "code": family_digest()})


def make_world(family: str, settings: EvalSettings, overrides: dict | None = None, where: str = "family settings",
               shift: float = SHIFT) -> World:
    """The World of `family` (BLOCKS: the block world of `settings.terrain`, which takes no overrides)."""
    if family == BLOCKS:
        if overrides:
            raise InputError(f"{where}: blocks: expected no overrides (the block world's settings are the params' "
                             f"modular.eval.terrain), found {sorted(overrides)}")
        return World(BLOCKS, settings.terrain, settings, shift)
    if family not in FAMILIES:
        raise InputError(f"family: unknown family {family!r}; expected one of {sorted([*FAMILIES, BLOCKS])}")
    return World(family, family_config(family, overrides, where), settings, shift)


Job = tuple[str, int, "int | None", World]  # (design, terrain seed, perturbation index or None, world)


def simulate_world(jobs: Sequence[Job]) -> list[dict]:
    """Rollouts of jobs as eval_cache rows; consecutive jobs on one terrain share a pybullet client."""
    rows = []
    for (seed, perturbation, world), group in itertools.groupby(jobs, key=lambda job: job[1:]):
        designs = [job[0] for job in group]
        rows += [{"reward": r.distance, "status": r.status, "sim_steps": r.sim_steps, "seconds": r.seconds}
                 for r in rollouts(designs, world.terrain(seed, perturbation), world.settings)]
    return rows


def mean_result(results: Sequence[Result]) -> Result:
    """One design's result over perturbations: the mean distance if every perturbation carries one, else no
    distance (never a mean over the survivors); the status is "ok" if all ran to the end, else the first other."""
    status = next((r.status for r in results if r.status != "ok"), "ok")
    distances = [r.distance for r in results]
    distance = None if any(d is None for d in distances) else float(np.mean(distances))
    if distance is None and status in REWARD_STATUSES:
        status = "unstable"
    return Result(distance, status, sum(r.sim_steps for r in results), sum(r.seconds for r in results))


def evaluate_world(designs: Sequence[str], seed: int, world: World, rule: FitnessRule, perturbations: int = 0,
                   cache: EvaluationCache | None = None, executor: Executor | None = None,
                   save_every: int = 0) -> list[Result]:
    """Results of `designs` on terrain `seed` of `world`: one rollout each, or with `perturbations` P >= 1 the
    mean over P perturbed terrains (`mean_result`). Designs the rule skips are not simulated."""
    if perturbations < 0:
        raise InputError(f"perturbations: expected an integer >= 0, found {perturbations}")
    if world.family == BLOCKS and perturbations == 0:
        return evaluate_designs(designs, seed, world.settings, rule, cache, executor, save_every)
    cache = EvaluationCache() if cache is None else cache
    settings_hash = world.settings_hash()
    indices: list[int | None] = [None] if perturbations == 0 else list(range(perturbations))
    simulated = [d for d in designs if not rule.skips(d)]
    jobs = [(d, int(seed), i, world) for i in indices for d in simulated]  # by perturbation: one terrain per chunk

    def key(job: Job) -> tuple:
        return job[0], world.task_id(job[1], job[2]), settings_hash, SEED

    missing = sum(key(job) not in cache for job in jobs)
    size = chunk_size(missing, 1 if executor is None else executor.workers)
    rows = evaluate_many(simulate_world, jobs, key, cache, executor, save_every, batch=size)
    by_design: dict[str, list[Result]] = {}
    for job, row in zip(jobs, rows, strict=True):
        by_design.setdefault(job[0], []).append(
            Result(row["reward"], row["status"], int(row["sim_steps"]), float(row["seconds"])))
    skipped = Result(None, "invalid", 0, 0.0)
    return [skipped if rule.skips(d) else mean_result(by_design[d]) for d in designs]


def design_set(name: str, pool_dir: Path = POOL_DIR) -> list[str]:
    """The designs of set `name` (`DESIGN_SETS`), in port-string order."""
    if name not in DESIGN_SETS:
        raise InputError(f"design set: expected one of {list(DESIGN_SETS)}, found {name!r}")
    valid = [d for d in all_designs() if valid_in_original(d)]
    if name == "all":
        return sorted(valid)
    paths = sorted(Path(pool_dir).glob("blocks-*.parquet"))
    if not paths:
        raise InputError(f"{pool_dir}: no block pool tables (blocks-<seed>.parquet); the {name!r} design set ranks "
                         "designs by their mean over them")
    pool = pd.concat([read_table(p, "modular_exhaustive") for p in paths], ignore_index=True)
    means = pool.pivot(index="design", columns="terrain_seed", values="distance").dropna().mean(axis=1)
    ranked = sorted(means.index, key=lambda d: (-means[d], d))
    chosen: list[str] = []
    if name == "balanced":
        classes: dict[str, list[str]] = {}
        for d in ranked:
            classes.setdefault("".join(sorted(set(d) - {"n"})), []).append(d)
        chosen = [d for members in classes.values() for d in members[:CLASS_QUOTA]]
    chosen += [d for d in ranked if d not in set(chosen)][:max(0, SET_SIZE - len(chosen))]
    return sorted(chosen[:SET_SIZE])


def record(world: World, rule: FitnessRule, perturbations: int, design_set_name: str) -> dict:
    """What a probe table's numbers depend on (plain JSON): family and settings, episode, fitness rule, the
    perturbations, the design set, and the digest of the code that made them."""
    digest = physics_digest() if world.family == BLOCKS and perturbations == 0 else family_digest()
    return json.loads(json.dumps({
        "family": world.family, "family_settings": asdict(world.config), "settings": asdict(world.settings),
        "fitness": asdict(rule), "perturbations": int(perturbations),
        "shift": world.shift if perturbations else None, "design_set": design_set_name, "digest": digest},
        sort_keys=True))


def default_directory(family: str, perturbations: int) -> Path:
    return FAMILIES_DIR / (family if perturbations == 0 else f"{family}_p{perturbations}")


def table_path(directory: Path, family: str, seed: int) -> Path:
    return Path(directory) / f"{family}-{int(seed)}.parquet"


def _stored_record(path: Path) -> dict:
    document = read_json(path.with_suffix(".json"))
    if not isinstance(document, dict) or any(k not in document for k in RECORD_KEYS):
        raise ArtifactError(f"{path.with_suffix('.json')}: expected a family table's record with fields "
                            f"{list(RECORD_KEYS)}")
    return document


def probe_terrain(seed: int, world: World, rule: FitnessRule, perturbations: int, designs: Sequence[str],
                  cache: EvaluationCache | None, executor: Executor | None, save_every: int = 32) -> pd.DataFrame:
    """One terrain's table (modular_exhaustive schema) over `designs`, sorted by design. The block world unperturbed
    is read from its committed tables (test or pool) where one matches: the same numbers, no rollout."""
    designs = sorted(designs)
    if world.family == BLOCKS and perturbations == 0:
        for directory in (COMMITTED_DIR, POOL_DIR):
            committed = read_committed(seed, world.settings, rule, directory)
            if committed is not None:
                return committed[committed.design.isin(designs)].sort_values("design", ignore_index=True)
    results = evaluate_world(designs, seed, world, rule, perturbations, cache, executor, save_every)
    return pd.DataFrame({"terrain_seed": int(seed), "design": designs,
                         "fitness": [rule.fitness(r) for r in results], "distance": [r.distance for r in results],
                         "status": [r.status for r in results], "sim_steps": [r.sim_steps for r in results],
                         "seconds": [r.seconds for r in results]})


def probe(world: World, seeds: Sequence[int], rule: FitnessRule, perturbations: int, design_set_name: str,
          designs: Sequence[str], cache: EvaluationCache, executor: Executor | None, directory: Path,
          on_terrain: Callable[[dict], None] | None = None) -> list[Path]:
    """Measure and keep one table per terrain seed under `directory` (see the module docstring); `on_terrain` gets
    a summary of each terrain as it is done."""
    expected = record(world, rule, perturbations, design_set_name)
    paths = []
    for seed in seeds:
        path = table_path(directory, world.family, seed)
        kept = path.exists() and path.with_suffix(".json").exists() and \
            {k: _stored_record(path)[k] for k in RECORD_KEYS} == expected
        started = time.perf_counter()
        if kept:
            table = read_table(path, "modular_exhaustive")
        else:
            table = probe_terrain(seed, world, rule, perturbations, designs, cache, executor)
            cache.save()
            write_table(table, path, "modular_exhaustive")
            atomic_write_json(path.with_suffix(".json"), {
                **expected, "terrain_seed": int(seed), "designs": len(table),
                "simulated": int((table.sim_steps > 0).sum()),
                "wall_seconds": round(time.perf_counter() - started, 1)})
        best = table.sort_values(["fitness", "design"], ascending=[False, True]).iloc[0]
        if on_terrain is not None:
            on_terrain({"terrain_seed": int(seed), "table": str(path), "source": "kept" if kept else "measured",
                        "optimum": float(best.fitness), "best_design": best.design,
                        "max_height": round(world.terrain(seed, None).max_height, 4)})
        paths.append(path)
    return paths


def _directory_terrains(directory: Path) -> tuple[list[Path], dict, Callable[[int], Terrain]]:
    """A directory's tables, the provenance they share, and how to remake each one's (unperturbed) terrain:
    a family probe's directory or one of the block world's committed tables (`truth.read_record`)."""
    paths = sorted(p for p in Path(directory).glob("*-*.parquet"))
    if not paths:
        raise InputError(f"--dir {directory}: no tables (<family>-<seed>.parquet) there")
    records = []
    for path in paths:
        if not path.with_suffix(".json").exists():
            raise InputError(f"{path}: its provenance record {path.with_suffix('.json').name} is missing")
        document = read_json(path.with_suffix(".json"))
        if isinstance(document, dict) and "family" in document:
            records.append({k: _stored_record(path)[k] for k in RECORD_KEYS})
        else:
            records.append({**read_record(path).provenance, "family": BLOCKS})
    differing = next((p for p, r in zip(paths, records, strict=True) if r != records[0]), None)
    if differing is not None:
        raise InputError(f"{differing}: measured under other settings than {paths[0]} (a gate reads one world)")
    shared = records[0]
    if shared["family"] == BLOCKS:
        terrain = TerrainConfig(**shared["settings"]["terrain"])
        return paths, shared, lambda seed: generate_terrain(seed, terrain)
    config = family_config(shared["family"], shared["family_settings"], f"{paths[0].with_suffix('.json')}")
    return paths, shared, lambda seed: generate(shared["family"], seed, config)


def gate_directories(directories: Sequence[Path], config: GateConfig | None = None) -> GateResult:
    """The gate on the tables of one world spread over `directories` (e.g. the block pool and test tables): the
    designs every terrain has a simulated fitness for, height-map features of each (unperturbed) terrain."""
    frames, features, provenance = [], {}, None
    for directory in directories:
        paths, shared, terrain_of = _directory_terrains(directory)
        if provenance is not None and shared != provenance:
            raise InputError(f"--dir {directory}: measured under other settings than {directories[0]}")
        provenance = shared
        for path in paths:
            table = read_table(path, "modular_exhaustive")
            seed = int(table.terrain_seed.iloc[0])
            frames.append(table[table.status != "invalid"])
            features[seed] = height_map_features(height_map(terrain_of(seed)))
    wide = pd.concat(frames).pivot(index="terrain_seed", columns="design", values="fitness").dropna(axis=1)
    if wide.shape[1] == 0:
        raise InputError(f"--dir {[str(d) for d in directories]}: no design has a fitness on every terrain")
    result = gate(wide, pd.DataFrame([features[s] for s in wide.index], index=wide.index), config or GateConfig())
    result.summary.update({"family": provenance["family"], "directories": [str(d) for d in directories],
                           "perturbations": provenance.get("perturbations", 0)})
    return result
