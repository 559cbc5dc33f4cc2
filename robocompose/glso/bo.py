"""GLSO: Bayesian optimisation in a graph VAE's latent space (thesis 8; JiahengHu/GLSO run_bo.py), bayes_opt 3.

The loop, one objective call per step:
- steps 0 .. init-1: random points inside the bounds [-3, 3]^latent (paper 50);
- every later step i: a random point when (i - init + 1) % 10 == 0 (GLSO's --rd_explore), else the
  suggestion of expected improvement (xi 0.01) on a GP (Matern nu 2.5, alpha 1e-3, normalised targets);
- (the acquisition's L-BFGS-B gets its finite-difference gradient from one batched GP call, see
  `ExpectedImprovement`: faster, the same search);
- the latent point is decoded greedily into a design; the design's score (the invalid score when it
  cannot be simulated) is registered at that point;
- after every step past the initial points, sequential domain reduction (gamma_osc 0.7, gamma_pan 1.0,
  eta 0.9) shrinks the bounds, exactly the call `maximize()` makes: set_bounds(transformer.transform(space)).
Random points are drawn inside the current (reduced) bounds, as in the original. The variants a practitioner
tries when the window collapses (issue 42; registered beside GLSO, each with its own defaults): no domain reduction
(`NoReductionConfig`: the original's README command), a wider floor (`WideFloorConfig`: `minimum_window` 2 of 6),
and re-asking (`ReaskConfig`): a suggestion that decodes to a design the run has scored is registered at that
score without an objective call and BO is asked again, at most `reask` times, then a random point of the current
bounds goes instead (the re-asks are the proposal's `rejected`: counted, not paid). The best so far is taken
from the whole history by the run, not from `optimizer.max`, which only sees points inside the current
bounds. A resumed run rebuilds the optimiser by replaying its steps (`runs.replay`: the seeded optimiser
suggests the recorded points again and registers their scores), not with bayes_opt's own `load_state`, which
re-initialises the domain-reduction transformer from the reduced bounds, so a resumed run would diverge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from bayes_opt import BayesianOptimization, SequentialDomainReductionTransformer, acquisition
from scipy.optimize import minimize

from robocompose.glso.method import Proposal, SearchEnv
from robocompose.grammar.tree import DesignTree
from robocompose.io.errors import check_field


@dataclass(frozen=True)
class BOConfig:
    bound: float = 3.0  # every latent coordinate lies in [-bound, bound]
    init: int = 50  # random initial points (paper 50)
    random_every: int = 10  # every 10th step after the initial points is a random point (0 = never)
    xi: float = 0.01  # expected improvement's exploration margin
    alpha: float = 1e-3  # GP noise added to the kernel's diagonal
    domain_reduction: bool = True
    gamma_osc: float = 0.7
    gamma_pan: float = 1.0
    eta: float = 0.9
    minimum_window: float = 0.5  # narrowest a reduced window may get
    reask: int = 0  # suggestions of a scored design registered for free per call, then a random point (0 = off)

    def __post_init__(self) -> None:
        check_field(self.bound > 0, "bound", "a positive number", self.bound)
        check_field(self.init >= 1, "init", "at least 1 random initial point", self.init)
        check_field(self.random_every >= 0, "random_every", ">= 0 (0 = never)", self.random_every)
        check_field(0 < self.minimum_window <= 2 * self.bound, "minimum_window",
                    f"a width in (0, {2 * self.bound}] (2 x bound)", self.minimum_window)
        check_field(self.reask >= 0, "reask", "an integer >= 0 (0 = a repeat is sent and costs its call)",
                    self.reask)


@dataclass(frozen=True)
class NoReductionConfig(BOConfig):
    """GLSO without domain reduction: the window stays [-bound, bound] (the original's README command)."""

    domain_reduction: bool = False


@dataclass(frozen=True)
class WideFloorConfig(BOConfig):
    """GLSO whose reduced window never gets narrower than a third of the box in any coordinate."""

    minimum_window: float = 2.0


@dataclass(frozen=True)
class ReaskConfig(BOConfig):
    """GLSO that asks again, for free, when a suggestion decodes to a design it has scored (at most 3 times)."""

    reask: int = 3


class ExpectedImprovement(acquisition.ExpectedImprovement):
    """bayes_opt's expected improvement, maximised the same way (10,000 random points, then L-BFGS-B from the
    best 10), with one change of speed only: L-BFGS-B gets the forward-difference gradient scipy would
    compute (step sqrt(eps) max(1, |x|), signed like x, turned back at an upper bound) from one batched GP
    prediction of the d + 1 points instead of d + 1 separate predictions (28 dimensions: ~29x fewer calls).
    """

    def _smart_minimize(self, acq, space, x_seeds, random_state):
        bounds = space.bounds
        step_size = np.sqrt(np.finfo(float).eps)

        def value_and_gradient(x: np.ndarray) -> tuple[float, np.ndarray]:
            h = step_size * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))  # (d,)
            h = np.where(x + h > bounds[:, 1], -np.abs(h), h)
            values = acq(np.vstack([x, x + np.diag(h)]))  # (d + 1,)
            return float(values[0]), (values[1:] - values[0]) / h

        best_x, best_value = None, np.inf
        for x_try in x_seeds:
            res = minimize(value_and_gradient, x_try, bounds=bounds, method="L-BFGS-B", jac=True)
            if res.success and res.fun < best_value:
                best_x, best_value = res.x, float(res.fun)
        if best_x is None:
            return np.full(len(bounds), np.nan), np.inf
        return np.clip(best_x, bounds[:, 0], bounds[:, 1]), best_value


def decode(model, z: np.ndarray) -> DesignTree:
    """Greedy decoding of one latent point (latent,) into a design tree."""
    with torch.no_grad():
        return model.decoder.decode(torch.as_tensor(z, dtype=torch.float32)[None])[0].tree()


class LatentBO:
    def __init__(self, config: BOConfig, seed: int, budget: int, env: SearchEnv) -> None:
        self.config = config
        # zero-padded: bayes_opt's key order is latent order
        self.keys = [f"z{i:03d}" for i in range(env.model.config.latent)]
        transformer = (SequentialDomainReductionTransformer(gamma_osc=config.gamma_osc, gamma_pan=config.gamma_pan,
                                                            eta=config.eta, minimum_window=config.minimum_window)
                       if config.domain_reduction else None)
        self.optimizer = BayesianOptimization(
            f=None, pbounds={k: (-config.bound, config.bound) for k in self.keys},
            acquisition_function=ExpectedImprovement(xi=config.xi), random_state=seed, verbose=0,
            bounds_transformer=transformer, allow_duplicate_points=True)
        self.optimizer.set_gp_params(alpha=config.alpha)  # the kernel stays bayes_opt's Matern(nu=2.5)
        self.step = 0
        self.scores: dict[str, float] = {}  # design id -> the score it was told (the designs this run scored)

    def is_random_step(self) -> bool:
        c, i = self.config, self.step - self.config.init
        return i < 0 or (c.random_every > 0 and (i + 1) % c.random_every == 0)

    def propose(self, env: SearchEnv) -> Proposal:
        if self.is_random_step():
            return self._decoded(env, self.optimizer.random_sample(1)[0])
        proposal, reasked = self._decoded(env, self.optimizer.suggest()), 0
        while self.config.reask and proposal.tree.design_id in self.scores:
            if reasked == self.config.reask:  # bounded: a random point instead of a paid repeat
                proposal = self._decoded(env, self.optimizer.random_sample(1)[0])
                break
            self.optimizer.register(self._params(proposal.z), self.scores[proposal.tree.design_id])
            proposal, reasked = self._decoded(env, self.optimizer.suggest()), reasked + 1
        proposal.rejected = reasked
        return proposal

    def _decoded(self, env: SearchEnv, params: dict) -> Proposal:
        z = np.array([params[k] for k in self.keys], dtype=np.float64)
        return Proposal(decode(env.model, z), None, z=z)

    def _params(self, z: np.ndarray) -> dict:
        return dict(zip(self.keys, z.tolist(), strict=True))

    def tell(self, proposal: Proposal, score: float) -> None:
        if proposal.tree is not None:
            self.scores.setdefault(proposal.tree.design_id, score)
        self.optimizer.register(self._params(proposal.z), score)
        if self.config.domain_reduction and self.step >= self.config.init:
            self.optimizer.set_bounds(self.optimizer._bounds_transformer.transform(self.optimizer.space))
        self.step += 1
