"""Declared pyarrow schemas of every parquet table in the project, in one place.

Adding a table is one entry in `SCHEMAS` (plus one in `LIST_LENGTHS` per fixed-length list column).
`robocompose.io.tables` converts to and checks against these on every write and read.
"""

from __future__ import annotations

import pyarrow as pa


def _required(name: str, type_: pa.DataType) -> pa.Field:
    return pa.field(name, type_, nullable=False)


SCHEMAS: dict[str, pa.Schema] = {
    # One row per robot design. `parents[i]` is the parent node of node i in the design tree (-1 for
    # the root) and `tokens[i]` its node token (0..41); `rules` is the grammar rule sequence that
    # derives it (empty for designs not made by the grammar); `contacts` the 16 rest-contact features.
    "designs": pa.schema(
        [
            _required("design_id", pa.string()),
            _required("rules", pa.list_(pa.int16())),
            _required("parents", pa.list_(pa.int32())),
            _required("tokens", pa.list_(pa.int16())),
            _required("n_links", pa.int16()),
            _required("n_joints", pa.int16()),
            _required("contacts", pa.list_(pa.float32())),
        ]
    ),
    # One row per evaluation of a design on a task; `reward` is null when the evaluation did not
    # produce a score (e.g. status "crashed"), never a made-up number.
    "eval_cache": pa.schema(
        [
            _required("design_id", pa.string()),
            _required("task", pa.string()),
            _required("settings_hash", pa.string()),
            _required("seed", pa.int64()),
            pa.field("reward", pa.float64(), nullable=True),
            _required("status", pa.string()),
            _required("sim_steps", pa.int64()),
            _required("seconds", pa.float64()),
        ]
    ),
    # The evaluate_references stage: each named design (RoboGrammar's references, random dataset designs)
    # on each task; `objective` is what an optimiser sees (the reward if ok, else the status's penalty).
    "reference_evals": pa.schema([
        _required("name", pa.string()), _required("rules", pa.list_(pa.int16())),
        _required("design_id", pa.string()), _required("task", pa.string()),
        _required("settings_hash", pa.string()), _required("seed", pa.int64()),
        pa.field("reward", pa.float64(), nullable=True), _required("status", pa.string()),
        _required("sim_steps", pa.int64()), _required("objective", pa.float64())]),
    # Team formation (robocompose.teams). One row per Voronoi region of a terrain chip: its seed point
    # (the region raster is recomputed from the chip's seeds) and its terrain shares (sum to 1).
    "regions": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("source", pa.string()), ("split", pa.string()), ("region", pa.int16()),
        ("seed_x", pa.float64()), ("seed_y", pa.float64()), ("n_pixels", pa.int64()),
        ("water", pa.float64()), ("mountain", pa.float64()), ("plain", pa.float64()),
        ("city", pa.float64())]]),
    # Coverage cost of one integer allocation (allocation_id = hash of its K x O counts) on one chip.
    "teams_eval_cache": pa.schema([_required(n, t) for n, t in [
        ("allocation_id", pa.string()), ("chip_id", pa.string()), ("settings_hash", pa.string()),
        ("seed", pa.int64()), ("coverage_cost", pa.float64()), ("deployment_cost", pa.int64())]]),
    # One NSGA-II run (Table 5.4) and the points of its final front.
    "teams_nsga2": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("population", pa.int64()), ("seed", pa.int64()),
        ("generations", pa.int64()), ("hypervolume", pa.float64()), ("seconds", pa.float64()),
        ("evaluations", pa.int64())]]),
    "teams_fronts": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("population", pa.int64()), ("seed", pa.int64()),
        ("coverage_cost", pa.float64()), ("deployment_cost", pa.int64()), ("counts", pa.list_(pa.int16()))]]),
    # Coverage baselines of Table 5.5: method x chip x deployment budget x seed.
    "teams_coverage": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("chip_id", pa.string()), ("budget", pa.int64()), ("seed", pa.int64()),
        ("coverage_cost", pa.float64()), ("deployment_cost", pa.int64())]]),
    # Observations of the robots of one example allocation (for the trajectory picture).
    "teams_trajectories": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("robot", pa.int64()), ("species", pa.int16()), ("region", pa.int16()),
        ("step", pa.int16()), ("x", pa.float64()), ("y", pa.float64())]]),
    # Modular robots (robocompose.modular). Every design (6-letter port string) on every test terrain: its
    # fitness under the fitness rule, its measured distance (null when not simulated or unstable), status and
    # the sim steps it cost.
    "modular_exhaustive": pa.schema([
        _required("terrain_seed", pa.int64()), _required("design", pa.string()), _required("fitness", pa.float64()),
        pa.field("distance", pa.float64(), nullable=True), _required("status", pa.string()),
        _required("sim_steps", pa.int64())]),
    # One search run (GA-20, GA-50, GA-crowding, random sampling) on one test terrain: best design, distinct
    # solutions of its final population, mean best fitness under emergency constraints (and the exhaustive
    # optimum under the same constraints), designs evaluated and the sim steps they cost without a cache.
    "modular_runs": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("terrain_seed", pa.int64()), ("seed", pa.int64()), ("best_design", pa.string()),
        ("best_fitness", pa.float64()), ("distinct", pa.int64()), ("ec_fitness", pa.float64()),
        ("ec_optimum", pa.float64()), ("optimum", pa.float64()), ("evaluations", pa.int64()),
        ("sim_steps", pa.int64())]]),
    # The real-time test protocol (robocompose.modular.eggan_experiments, thesis Table 5.1): one row per method x
    # held-out test terrain x query; distances in m (NaN: no valid candidate / no exhaustive optimum).
    "modular_realtime": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("terrain_seed", pa.int64()), ("query", pa.int64()), ("candidates", pa.int64()),
        ("valid", pa.int64()), ("best_design", pa.string())]] + [
        pa.field("max_distance", pa.float64(), nullable=True), _required("distinct", pa.int64()),
        pa.field("ec_distance", pa.float64(), nullable=True), _required("ec_failures", pa.int64()),
        pa.field("optimum", pa.float64(), nullable=True), pa.field("regret", pa.float64(), nullable=True),
        _required("query_ms", pa.float64())]),
    # The latent landscape (robocompose.latent.landscape, thesis Fig. 7.1): one row per (VAE variant, dataset
    # design): the first two principal components of its latent mean (and the variance fraction each explains)
    # and, for the scored subset, the evaluator's flat-terrain status and reward ("" / null when not scored).
    "vae_landscape": pa.schema([
        _required("variant", pa.string()), _required("design_id", pa.string()), _required("pc1", pa.float64()),
        _required("pc2", pa.float64()), _required("explained1", pa.float64()), _required("explained2", pa.float64()),
        _required("status", pa.string()), pa.field("reward", pa.float64(), nullable=True)]),
}

# (table, column) -> exact number of values every row of that list column must hold.
LIST_LENGTHS: dict[tuple[str, str], int] = {
    ("designs", "contacts"): 16,
}


def get_schema(name: str) -> pa.Schema:
    """Return the declared schema `name`; KeyError listing the known names otherwise."""
    try:
        return SCHEMAS[name]
    except KeyError:
        raise KeyError(f"unknown table schema {name!r}; declared: {sorted(SCHEMAS)}") from None
