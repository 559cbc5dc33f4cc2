"""GLSO with a trust region: TuRBO-1 (Eriksson et al., NeurIPS 2019) in the graph VAE's latent space, with BoTorch
(issue 42, item 3: a latent BO that cannot collapse onto its incumbent for good: its region shrinks, then restarts).

The loop, one objective call per step (like every method of the comparison):
- steps 0 .. init-1: the first `init` points of a scrambled Sobol sequence seeded by the run seed, in the latent box
  [-bound, bound]^latent; the GP sees every point mapped to the unit cube [0, 1]^latent;
- every later step: a GP (SingleTaskGP: Matern 2.5 with one lengthscale per coordinate in [0.005, 4], scaled; a
  Gaussian likelihood with noise in [1e-8, 1e-3]; targets standardised) fitted by maximum marginal likelihood
  (fit_gpytorch_mll) in double precision; a trust region centred on the best point of the current restart, its side
  `length` times the GP's lengthscales normalised to geometric mean 1, clipped to the cube; `candidates` points
  that each copy the centre and replace every coordinate with probability min(20 / latent, 1) (at least one) by a
  Sobol point of the region; Thompson sampling: one joint draw of the posterior at the candidates, the best of
  which is the next point;
- every told score of such a step: a success if it beats the restart's best by 1e-3 of its size (score > best +
  1e-3 |best|), else a failure; `success_tolerance` successes in a row double `length` (at most `length_max`),
  `failure_tolerance` failures in a row halve it; below `length_min` the run restarts (below).
Every point is decoded greedily into a design (`bo.decode`) and sent with its latent point; a design seen before
still costs its call (the accounting rule of `runs.py`) and the method is told the score the run got (an invalid
design's score included, as GLSO's).

What differs from BoTorch's TuRBO-1 tutorial (tutorials/turbo_1):
- batch 1, not 4, so the failure tolerance is ceil(max(4, latent)) (the tutorial's ceil(max(4 / batch, dim / batch)));
- `success_tolerance` 3, the paper's (the tutorial uses 10);
- the initial design is `init` points (the campaign sets it as GLSO's, 50), not 2 x dim;
- a restart keeps the data. The tutorial discards it and draws 2 x dim new Sobol points (56 in the campaign's 28
  dimensions: more than a quarter of a 200-call run per restart); drawing `init` again would cost the same. Here a
  restart resets the trust region (length_init, no successes or failures) and spends one call on the next point of
  the run's Sobol sequence (space-filling against every point drawn so far), which is the new region's centre until
  a BO step beats it; success is counted against the new restart's best only. The GP is fitted on every point of
  the run: it cannot be fitted on one point, and the old points are exact evidence of the same objective (the
  paper discards them to keep the model local; the region already keeps the search local). At the campaign's
  settings no restart happens at all: with 28 dimensions a halving takes 28 failures in a row, and 150 BO steps
  give at most 5 halvings (0.8 -> 0.025 > length_min 0.0078), so the rule matters only for longer runs or small
  latents;
- the targets are standardised by BoTorch's Standardize (the tutorial standardises by hand, which divides by zero
  while every score is equal, e.g. all invalid);
- a candidate whose mask replaced no coordinate gets one drawn among all `latent` (the tutorial's
  randint(0, dim - 1) never picks the last);
- every random draw is seeded (the tutorial uses torch's global generator): the initial and restart points by the
  run seed (SobolEngine(seed=...)), a BO step's candidates, mask, Thompson draw and any refit of the GP by
  (run seed, step) under torch.random.fork_rng, so the method's state follows from the seed and what it was told,
  which `runs.replay` needs to resume a run.
Time (one thread, as `runs.run_search` runs, 28 dimensions): at 150 points a BO step takes ~0.6 s (GP fit ~0.3 s,
Thompson draw over 2000 candidates ~0.3 s), at 199 points ~1.5 s; the draw over the tutorial's 5000 candidates
alone takes ~4.5 s, a Cholesky factorisation of their 5000 x 5000 covariance (see `TurboConfig.candidates`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch
from torch.quasirandom import SobolEngine

from robocompose.glso.bo import decode
from robocompose.glso.method import Proposal, SearchEnv
from robocompose.io.errors import check_field

if TYPE_CHECKING:  # BoTorch and GPyTorch are imported where a BO step needs them: the registry imports this module
    from botorch.models import SingleTaskGP

DTYPE = torch.float64  # the GP's precision (the tutorial's)
SOBOL, TRUST_REGION = "sobol", "trust region"  # a proposal's `info`: an initial or restart point, or a BO step


@dataclass(frozen=True)
class TurboConfig:
    """The `glso.bo_turbo` section: TuRBO-1's settings (the paper's, as BoTorch's tutorial has them, with batch 1)."""

    bound: float = 3.0  # the latent box [-bound, bound]^latent, mapped to [0, 1]^latent for the GP
    init: int = 50  # Sobol initial points (scrambled, seeded by the run seed); the campaign sets it as GLSO's
    length_init: float = 0.8  # the trust region's side in the unit cube, before the lengthscale weights
    length_min: float = 0.5 ** 7  # a side below this restarts the search
    length_max: float = 1.6
    success_tolerance: int = 3  # successes in a row that double the side (the paper's 3; the tutorial uses 10)
    failure_tolerance: int = 0  # failures in a row that halve it; 0 = ceil(max(4, latent)) (the tutorial's, batch 1)
    # Thompson sampling's candidates; 0 = min(5000, max(2000, 200 x latent)), the tutorial's: 5000 in 28 dimensions,
    # whose joint draw (a 5000 x 5000 Cholesky factorisation) takes ~4.5 s a step on one thread, so the default is
    # the tutorial's floor 2000 (~0.3 s a draw)
    candidates: int = 2000

    def __post_init__(self) -> None:
        check_field(self.bound > 0, "bound", "a positive number", self.bound)
        check_field(self.init >= 1, "init", "at least 1 initial point", self.init)
        check_field(0 < self.length_min <= self.length_init <= self.length_max, "length_init",
                    f"a side in [length_min, length_max] = [{self.length_min}, {self.length_max}], length_min > 0",
                    self.length_init)
        check_field(self.success_tolerance >= 1, "success_tolerance", "an integer >= 1", self.success_tolerance)
        check_field(self.failure_tolerance >= 0, "failure_tolerance", "an integer >= 0 (0 = ceil(max(4, latent)))",
                    self.failure_tolerance)
        check_field(self.candidates >= 0, "candidates", "an integer >= 0 (0 = min(5000, max(2000, 200 x latent)))",
                    self.candidates)


@dataclass
class TrustRegion:
    """The state of the current restart's trust region (the tutorial's TurboState, batch 1)."""

    length: float
    best: float = -math.inf  # the best score of the current restart
    successes: int = 0
    failures: int = 0


def step_seed(seed: int, step: int) -> int:
    """The seed of step `step`'s random draws: one stream per (run seed, step), from NumPy's seed sequence."""
    return int(np.random.SeedSequence([seed, step]).generate_state(1)[0])


def fit_gp(x: torch.Tensor, y: torch.Tensor) -> SingleTaskGP:
    """The tutorial's GP on points `x` (n, d) of the unit cube and scores `y` (n, 1), fitted."""
    from botorch.exceptions.warnings import OptimizationWarning
    from botorch.fit import fit_gpytorch_mll
    from botorch.models import SingleTaskGP
    from botorch.models.transforms.outcome import Standardize
    from gpytorch.constraints import Interval
    from gpytorch.kernels import MaternKernel, ScaleKernel
    from gpytorch.likelihoods import GaussianLikelihood
    from gpytorch.mlls import ExactMarginalLogLikelihood

    covar = ScaleKernel(MaternKernel(nu=2.5, ard_num_dims=x.shape[-1], lengthscale_constraint=Interval(0.005, 4.0)))
    likelihood = GaussianLikelihood(noise_constraint=Interval(1e-8, 1e-3))
    model = SingleTaskGP(x, y, covar_module=covar, likelihood=likelihood, outcome_transform=Standardize(m=1))
    with warnings.catch_warnings():  # an optimiser that stops early still leaves a usable GP (BoTorch retries first)
        warnings.simplefilter("ignore", OptimizationWarning)
        fit_gpytorch_mll(ExactMarginalLogLikelihood(model.likelihood, model))
    return model


def thompson_candidate(model: SingleTaskGP, center: torch.Tensor, length: float, candidates: int,
                       seed: int) -> torch.Tensor:
    """The tutorial's `generate_batch` (Thompson sampling, batch 1): the candidate (d,) of the trust region of side
    `length` around `center` whose joint posterior draw is highest. Draws from torch's global generator, which the
    caller has seeded."""
    from botorch.generation import MaxPosteriorSampling

    dim = center.shape[-1]
    weights = model.covar_module.base_kernel.lengthscale.detach().reshape(-1)
    weights = weights / torch.exp(torch.log(weights).mean())  # geometric mean 1
    lower = torch.clamp(center - weights * length / 2.0, 0.0, 1.0)
    upper = torch.clamp(center + weights * length / 2.0, 0.0, 1.0)
    perturbed = lower + (upper - lower) * SobolEngine(dim, scramble=True, seed=seed).draw(candidates, dtype=DTYPE)
    mask = torch.rand(candidates, dim, dtype=DTYPE) <= min(20.0 / dim, 1.0)
    empty = torch.where(mask.sum(dim=1) == 0)[0]
    mask[empty, torch.randint(0, dim, (len(empty),))] = True
    x = center.expand(candidates, dim).clone()
    x[mask] = perturbed[mask]
    with torch.no_grad():
        return MaxPosteriorSampling(model=model, replacement=False)(x, num_samples=1)[0]


class TrustRegionBO:
    """TuRBO-1 in the latent space (the module docstring): `propose` / `tell` of `method.SearchMethod`."""

    def __init__(self, config: TurboConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config, self.seed = config, seed
        self.dim = env.model.config.latent
        self.failure_tolerance = config.failure_tolerance or math.ceil(max(4.0, float(self.dim)))
        self.candidates = config.candidates or min(5000, max(2000, 200 * self.dim))
        self.sobol = SobolEngine(self.dim, scramble=True, seed=seed)
        self.queue = list(self.sobol.draw(config.init, dtype=DTYPE))  # unit-cube points to send before BO steps
        self.x: list[torch.Tensor] = []  # every point told, in the unit cube
        self.y: list[float] = []  # and its score
        self.restart_start = 0  # index of the current restart's first point
        self.region = TrustRegion(config.length_init)
        self.restarts = 0
        self.step = 0

    def propose(self, env: SearchEnv) -> Proposal:
        if self.queue:
            return self._decoded(env, self.queue[0], SOBOL)
        import gpytorch

        seed = step_seed(self.seed, self.step)
        x, y = torch.stack(self.x), torch.tensor(self.y, dtype=DTYPE)[:, None]
        center = x[self.restart_start + int(torch.argmax(y[self.restart_start:]))]
        with torch.random.fork_rng(devices=[]), gpytorch.settings.max_cholesky_size(float("inf")):
            torch.manual_seed(seed)
            model = fit_gp(x, y)
            point = thompson_candidate(model, center, self.region.length, self.candidates, seed)
        return self._decoded(env, point, TRUST_REGION)

    def _decoded(self, env: SearchEnv, x: torch.Tensor, kind: str) -> Proposal:
        z = (x.numpy().astype(np.float64) * 2.0 - 1.0) * self.config.bound  # unit cube -> latent box
        return Proposal(decode(env.model, z), None, z=z, info=(kind, x))

    def tell(self, proposal: Proposal, score: float) -> None:
        kind, x = proposal.info
        self.x.append(x)
        self.y.append(float(score))
        if kind == SOBOL:
            self.queue.pop(0)
            self.region.best = max(self.region.best, float(score))
        else:
            self._update(float(score))
        self.step += 1

    def _update(self, score: float) -> None:
        """The tutorial's `update_state` for one score, and the restart below `length_min`."""
        region, c = self.region, self.config
        if score > region.best + 1e-3 * abs(region.best):
            region.successes, region.failures = region.successes + 1, 0
        else:
            region.successes, region.failures = 0, region.failures + 1
        if region.successes == c.success_tolerance:
            region.length, region.successes = min(2.0 * region.length, c.length_max), 0
        elif region.failures == self.failure_tolerance:
            region.length, region.failures = region.length / 2.0, 0
        region.best = max(region.best, score)
        if region.length < c.length_min:  # restart: a fresh region at the next Sobol point (module docstring)
            self.region, self.restart_start = TrustRegion(c.length_init), len(self.x)
            self.queue.append(self.sobol.draw(1, dtype=DTYPE)[0])
            self.restarts += 1
