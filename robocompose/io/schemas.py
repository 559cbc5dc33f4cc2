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
    # GLSO search (robocompose.glso): one row per objective call of a run (task, method, seed). `rules` is
    # the design's grammar derivation (empty if the grammar cannot make it), `parents`/`tokens` its tree,
    # `latent` the latent point it was decoded from (empty for non-latent methods); `score` is what the
    # method was told (the reward if ok, else the status's invalid score); `repeat` marks a design already
    # evaluated earlier in the run (it costs a call and gets its cached score). Wall times are not stored
    # here (identical runs give identical bytes): the stage puts each run's seconds in reports/timings.json.
    "glso_steps": pa.schema([
        _required("step", pa.int32()), _required("method", pa.string()), _required("task", pa.string()),
        _required("seed", pa.int64()), _required("design_id", pa.string()),
        _required("rules", pa.list_(pa.int16())), _required("parents", pa.list_(pa.int32())),
        _required("tokens", pa.list_(pa.int16())), _required("latent", pa.list_(pa.float64())),
        _required("score", pa.float64()), pa.field("reward", pa.float64(), nullable=True),
        _required("status", pa.string()), _required("repeat", pa.bool_()),
        _required("rejected", pa.int64()),  # designs the method discarded before this one (no call spent)
        pa.field("best_so_far", pa.float64(), nullable=True)]),  # best simulated reward; null before the first
    # Team formation (robocompose.teams). One row per region of a terrain chip: its centre in the joint
    # position + terrain space (seed_x, seed_y, seed_<terrain> shares) and the terrain weight (the region
    # raster is recomputed from them, teams.decompose), its size and its terrain shares (sum to 1).
    "regions": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("source", pa.string()), ("split", pa.string()), ("region", pa.int16()),
        ("seed_x", pa.float64()), ("seed_y", pa.float64()), ("seed_water", pa.float64()),
        ("seed_mountain", pa.float64()), ("seed_plain", pa.float64()), ("seed_city", pa.float64()),
        ("terrain_weight", pa.float64()), ("n_pixels", pa.int64()),
        ("water", pa.float64()), ("mountain", pa.float64()), ("plain", pa.float64()),
        ("city", pa.float64())]]),
    # Mean region purity (share of the dominant terrain) of every chip: terrain-driven decomposition and
    # the plain Voronoi of the same initial seeds.
    "regions_purity": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("method", pa.string()), ("purity", pa.float64())]]),
    # One team's coverage cost a_i E_i / G_i in its region (teams/evaluator.py): team = "region:n_1-..-n_O".
    "teams_team_costs": pa.schema([_required(n, t) for n, t in [
        ("team", pa.string()), ("chip_id", pa.string()), ("settings_hash", pa.string()),
        ("seed", pa.int64()), ("team_cost", pa.float64())]]),
    # One NSGA-II run (Table 5.4) and the points of its final front (its wall time: reports/timings.json);
    # genome: a name of teams.nsga2.GENOMES.
    "teams_nsga2": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("genome", pa.string()), ("population", pa.int64()), ("seed", pa.int64()),
        ("generations", pa.int64()), ("hypervolume", pa.float64()), ("evaluations", pa.int64()),
        ("team_lookups", pa.int64()), ("distinct_teams", pa.int64())]]),
    "teams_fronts": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("genome", pa.string()), ("population", pa.int64()), ("seed", pa.int64()),
        ("coverage_cost", pa.float64()), ("deployment_cost", pa.int64()), ("counts", pa.list_(pa.int16()))]]),
    # Table 5.4's random-allocation fronts: per chip x seed, of the first `draws` draws of NSGA-II's first-population
    # sampler, the hypervolume, the front's size and the distinct teams those draws optimised.
    "teams_random_fronts": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("seed", pa.int64()), ("draws", pa.int64()), ("hypervolume", pa.float64()),
        ("front_size", pa.int64()), ("distinct_teams", pa.int64())]]),
    # The points of Table 5.4's random-allocation fronts (the non-dominated set of the first `draws` draws).
    "teams_random_points": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("seed", pa.int64()), ("draws", pa.int64()), ("coverage_cost", pa.float64()),
        ("deployment_cost", pa.int64()), ("counts", pa.list_(pa.int16()))]]),
    # Every front re-measured at held-out robot-start seeds (teams/heldout.py): per method x chip x search seed
    # the hypervolume at the search seed and of the same allocations at their mean held-out cost; and Table
    # 5.5's picks: the best point within each budget at the search seed (selected_cost; NaN for the single
    # draws, which select nothing) and its mean and sd over the held-out seeds.
    "teams_heldout_fronts": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("title", pa.string()), ("chip_id", pa.string()), ("seed", pa.int64()),
        ("hypervolume", pa.float64()), ("heldout_hypervolume", pa.float64()), ("front_size", pa.int64()),
        ("distinct_teams", pa.int64())]]),
    "teams_heldout_picks": pa.schema([
        *[_required(n, t) for n, t in [("method", pa.string()), ("title", pa.string()), ("chip_id", pa.string()),
                                       ("seed", pa.int64()), ("budget", pa.int64())]],
        pa.field("selected_cost", pa.float64()),
        *[_required(n, t) for n, t in [("heldout_mean", pa.float64()), ("heldout_sd", pa.float64()),
                                       ("deployment_cost", pa.int64())]]]),
    # Coverage baselines of Table 5.5: method x chip x deployment budget x seed; empty_regions: regions
    # without robots (decomposed) or that no observation falls in (no decomposition).
    "teams_coverage": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("chip_id", pa.string()), ("budget", pa.int64()), ("seed", pa.int64()),
        ("coverage_cost", pa.float64()), ("deployment_cost", pa.int64()), ("empty_regions", pa.int64())]]),
    # EG-GAN queries on held-out chips (Tables 5.4, 5.5): per chip x seed the hypervolume of the front of
    # `samples` noise vectors, the distinct allocations and teams among them and the front's size; and the fronts.
    "teams_eggan_queries": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("seed", pa.int64()), ("hypervolume", pa.float64()), ("distinct", pa.int64()),
        ("distinct_teams", pa.int64()), ("front_size", pa.int64())]]),
    "teams_eggan_fronts": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("seed", pa.int64()), ("coverage_cost", pa.float64()),
        ("deployment_cost", pa.int64()), ("counts", pa.list_(pa.int16()))]]),
    # Observations of the robots of the three methods of Table 5.5 at one budget on a few test chips (Fig. 5.4).
    "teams_coverage_examples": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("chip_id", pa.string()), ("robot", pa.int64()), ("species", pa.int16()),
        ("step", pa.int16()), ("x", pa.float64()), ("y", pa.float64())]]),
    # Observations of the robots of one example allocation (for the trajectory picture).
    "teams_trajectories": pa.schema([_required(n, t) for n, t in [
        ("chip_id", pa.string()), ("robot", pa.int64()), ("species", pa.int16()), ("region", pa.int16()),
        ("step", pa.int16()), ("x", pa.float64()), ("y", pa.float64())]]),
    # Modular robots (robocompose.modular). Every design (6-letter port string) on every truth terrain: its
    # fitness under the fitness rule, its measured distance (null when not simulated or unstable), status, and
    # the sim steps and seconds it cost (0 when not simulated).
    "modular_exhaustive": pa.schema([
        _required("terrain_seed", pa.int64()), _required("design", pa.string()), _required("fitness", pa.float64()),
        pa.field("distance", pa.float64(), nullable=True), _required("status", pa.string()),
        _required("sim_steps", pa.int64()), _required("seconds", pa.float64())]),
    # One search run (GA-20, GA-50, GA-crowding, random sampling) on one test terrain: best design and its
    # distance (null: no design it saw carried one), distinct solutions of its final population, mean distance of
    # its emergency-constraint answers that carry one (null if none) and the count of those that do not, the
    # exhaustive optimum (under the same constraints, and overall), designs evaluated and the sim steps and
    # measured simulation seconds they cost without a cache.
    "modular_runs": pa.schema([
        _required("method", pa.string()), _required("terrain_seed", pa.int64()), _required("seed", pa.int64()),
        _required("best_design", pa.string()), pa.field("best_distance", pa.float64(), nullable=True),
        _required("distinct", pa.int64()), pa.field("ec_distance", pa.float64(), nullable=True),
        _required("ec_failures", pa.int64()), _required("ec_optimum", pa.float64()),
        _required("optimum", pa.float64()), _required("evaluations", pa.int64()), _required("sim_steps", pa.int64()),
        _required("sim_seconds", pa.float64())]),
    # The real-time test protocol (robocompose.modular.experiments.protocol, thesis Table 5.1): one row per
    # method x held-out test terrain x query, and for a learned row per training seed (training_seed: the seed of
    # the model that answered; 0 for the rows no model answers); distances in m (NaN: no valid candidate / no
    # exhaustive optimum). Query wall times go to reports/timings.json, not here (identical runs give identical bytes).
    "modular_realtime": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("terrain_seed", pa.int64()), ("query", pa.int64()), ("candidates", pa.int64()),
        ("valid", pa.int64()), ("best_design", pa.string())]] + [
        pa.field("max_distance", pa.float64(), nullable=True), _required("distinct", pa.int64()),
        pa.field("ec_distance", pa.float64(), nullable=True), _required("ec_failures", pa.int64()),
        pa.field("optimum", pa.float64(), nullable=True), pa.field("regret", pa.float64(), nullable=True),
        _required("training_seed", pa.int64())]),
    # The pool-size study (robocompose.modular.experiments.pool_size): a modular_realtime row per test query,
    # with the training pool's size, the iterations its EG-GAN-crowding trained and the distinct look-ups it made.
    "modular_pool_size": pa.schema([_required(n, t) for n, t in [
        ("method", pa.string()), ("terrain_seed", pa.int64()), ("query", pa.int64()), ("candidates", pa.int64()),
        ("valid", pa.int64()), ("best_design", pa.string())]] + [
        pa.field("max_distance", pa.float64(), nullable=True), _required("distinct", pa.int64()),
        pa.field("ec_distance", pa.float64(), nullable=True), _required("ec_failures", pa.int64()),
        pa.field("optimum", pa.float64(), nullable=True), pa.field("regret", pa.float64(), nullable=True),
        _required("pool_terrains", pa.int64()), _required("seed", pa.int64()), _required("iterations_done", pa.int64()),
        _required("lookups", pa.int64()), _required("train_max_distance", pa.float64())]),
    # The latent landscape (robocompose.latent.landscape, thesis Fig. 7.1): one row per (VAE variant, dataset
    # design): the first two principal components of its latent mean (and the variance fraction each explains)
    # and, for the scored subset, the evaluator's flat-terrain status and reward ("" / null when not scored).
    "vae_landscape": pa.schema([
        _required("variant", pa.string()), _required("design_id", pa.string()), _required("pc1", pa.float64()),
        _required("pc2", pa.float64()), _required("explained1", pa.float64()), _required("explained2", pa.float64()),
        _required("status", pa.string()), pa.field("reward", pa.float64(), nullable=True),
        _required("source", pa.string()), _required("task", pa.string()), _required("rung", pa.string())]),
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
