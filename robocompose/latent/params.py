"""The `train_vae:` section of params.yaml (loaded by `robocompose.params.load_section`): shared model and training
settings and the three variants."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from robocompose.io.errors import InputError
from robocompose.latent.model import VAEConfig
from robocompose.latent.train import TrainConfig

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


@dataclass(frozen=True)
class TrainVaeParams:
    model: VAEConfig
    train: TrainConfig
    variants: dict[str, Variant]
    metrics: MetricsConfig = field(default_factory=MetricsConfig)
    extra: ExtraConfig = field(default_factory=ExtraConfig)
    landscape: dict = field(default_factory=dict)  # the vae_landscape stage's own section (LandscapeConfig)

    def variant(self, name: str) -> tuple[Variant, VAEConfig, TrainConfig, MetricsConfig]:
        """Variant `name`, the model config it implies (predictor, constraints), the training and metrics configs."""
        if name not in self.variants:
            raise InputError(f"variants: no variant {name!r}; known: {sorted(self.variants)}")
        variant = self.variants[name]
        model = replace(self.model, predictor=variant.predictor, constraints=variant.constraints)
        return variant, model, self.train, self.metrics
