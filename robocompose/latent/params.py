"""The `train_vae:` section of params.yaml: shared model/training settings and the three variants."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from robocompose.io.errors import InputError
from robocompose.latent.model import VAEConfig
from robocompose.latent.train import TrainConfig
from robocompose.params import build_config, read_params

VARIANTS = ("full", "nopred", "nogram")


@dataclass(frozen=True)
class Variant:
    """One VAE of the ablation: its dataset, whether it has a predictor, its decoding constraints."""

    data: str  # designs table (split into training and held-out designs)
    extra: str  # more designs of the same kind, for training only ("" = none)
    predictor: bool
    constraints: str  # grammar | tree


@dataclass(frozen=True)
class ExtraConfig:
    """The `train_vae.extra:` section: more designs from the dataset's own generators, for training only."""

    n: int = 0  # grammar designs (same enumeration as the dataset, another seed) and as many no-grammar ones
    seed: int = 1000

    def __post_init__(self) -> None:
        if self.n < 0:
            raise InputError(f"n must be >= 0, got {self.n}")


@dataclass(frozen=True)
class MetricsConfig:
    prior_samples: int = 1000  # z ~ N(0, I) decoded for validity, uniqueness and novelty
    seed: int = 0


def load_variant(name: str, path: str | Path = "params.yaml") -> tuple[Variant, VAEConfig, TrainConfig, MetricsConfig]:
    where = f"{path}: train_vae"
    section = read_params(path).get("train_vae")
    if not isinstance(section, dict):
        raise InputError(f"{path}: missing section 'train_vae'")
    variants = section.get("variants", {})
    if name not in variants:
        raise InputError(f"{where}.variants: no variant {name!r}; known: {sorted(variants)}")
    variant = build_config(Variant, variants[name], f"{where}.variants.{name}")
    model = build_config(VAEConfig, section.get("model"), f"{where}.model")
    model = replace(model, predictor=variant.predictor, constraints=variant.constraints)
    return (variant, model, build_config(TrainConfig, section.get("train"), f"{where}.train"),
            build_config(MetricsConfig, section.get("metrics", {}), f"{where}.metrics"))
