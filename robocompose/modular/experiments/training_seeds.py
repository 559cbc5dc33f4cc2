"""Further training seeds of Table 5.1's learners: the folders `robocompose modular train-seed` fills, checked
against the params before the stage `modular_realtime` answers the learned rows from them.

A folder `seed-S` (under measured/modular/seeds/) holds every learner's model `eggan_modular_NAME.pt` (with its
`.json`, checkpoint folder and curve) trained at training seed S with the params' settings otherwise. `further_seeds`
reads them all and refuses, before any work and with one line naming the file, the field, what it holds and what
was expected: a folder of another name, a learner's model missing, a seed that is a learner's own configured seed
(the stage's model already answers for it), and a model trained under other settings. Compared per model: the
evaluator's settings hash, every field of its training settings (`train`: the params' with the seed set to S,
`generative.training_config`), its network settings (`network`) and its fitness source and look-up budget
(`metrics`). The run key is not compared: it also digests the code, and a code change does not make a trained
model another setting's. A stale seed is never mixed in silently.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from typing import Any

from robocompose.eggan.learners import LEARNERS, baselines, variants
from robocompose.eggan.storage import load_model
from robocompose.io.errors import ArtifactError, shown
from robocompose.modular.eggan_params import EgganModularParams, network_of
from robocompose.modular.experiments.generative import configured_seed, training_config, with_seed
from robocompose.modular.params import ModularParams

SEED_FOLDER = re.compile(r"seed-(0|[1-9][0-9]*)")  # seed-S, S a training seed written without leading zeros


def _json(value: Any) -> Any:
    """`value` as a model file's info holds it (JSON: tuples become lists)."""
    return json.loads(json.dumps(value, sort_keys=True))


def expected_settings(method: str, seed: int, modular: ModularParams, params: EgganModularParams) -> dict[str, Any]:
    """Field -> the value learner `method`'s model file must hold when trained at `seed` under `params`: the
    evaluator's settings hash, every training setting (`train.NAME`), every network setting (`network.NAME`) and
    the fitness source and budget its metrics record (`metrics.NAME`)."""
    train = _json(dataclasses.asdict(training_config(method, with_seed(params, method, seed))))
    network = _json(dataclasses.asdict(network_of(method, params)))
    fitness = params.fitness
    budget = fitness.lookups if fitness.source == "table" else fitness.budget
    return {"settings_hash": modular.eval.settings_hash(),
            **{f"train.{name}": value for name, value in train.items()},
            **{f"network.{name}": value for name, value in network.items()},
            "metrics.fitness_source": fitness.source, "metrics.evaluation_budget": budget}


_MISSING = object()


def _found(info: dict, field: str) -> Any:
    value: Any = info
    for part in field.split("."):
        value = value.get(part, _MISSING) if isinstance(value, dict) else _MISSING
    return value


def check_seed_folder(folder: Path, seed: int, modular: ModularParams, params: EgganModularParams) -> None:
    """ArtifactError (one line) unless `folder` holds every learner's model trained at `seed` under `params`'
    settings, `seed` being none of the learners' own configured seeds (see the module docstring)."""
    retrain = f"robocompose modular train-seed --method {{}} --seed {seed} --out-dir {folder}"
    for method in (*variants("modular"), *baselines("modular")):
        title = LEARNERS["modular"][method].title
        own = configured_seed(method, params)
        if seed == own:
            raise ArtifactError(f"{folder}: training seed {seed}: expected a seed other than {title}'s own ({own}, "
                                f"models/eggan_modular_{method}.pt answers for it)")
        path = folder / f"eggan_modular_{method}.pt"
        if not path.is_file():
            raise ArtifactError(f"{path}: no such file (expected {title}'s model at training seed {seed}: "
                                f"{retrain.format(method)})")
        info = load_model(path, "a trained model")[0]
        for field, expected in expected_settings(method, seed, modular, params).items():
            found = _found(info, field)
            if found is _MISSING or found != expected:
                shown_found = "nothing" if found is _MISSING else shown(found)
                raise ArtifactError(f"{path}: {field}: expected {shown(expected)} (the params' settings at training "
                                    f"seed {seed}), found {shown_found}: trained under other settings (retrain: "
                                    f"{retrain.format(method)})")


def further_seeds(root: Path, modular: ModularParams, params: EgganModularParams) -> dict[int, Path]:
    """Training seed -> its folder under `root` (`root`/seed-S), every one checked (`check_seed_folder`), sorted
    by seed; none if `root` holds no seed folder (or does not exist). Files beside the folders (a README) and hidden
    entries are left alone; a folder of another name is an ArtifactError."""
    if not root.is_dir():
        return {}
    found: dict[int, Path] = {}
    for entry in sorted(root.iterdir()):
        if not entry.is_dir() or entry.name.startswith("."):
            continue
        match = SEED_FOLDER.fullmatch(entry.name)
        if match is None:
            raise ArtifactError(f"{entry}: expected a folder named seed-S (S a training seed, e.g. seed-1), found "
                                f"{entry.name!r}")
        check_seed_folder(entry, int(match.group(1)), modular, params)
        found[int(match.group(1))] = entry
    return dict(sorted(found.items()))
