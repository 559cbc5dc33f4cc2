"""Conditional MolGAN baseline (De Cao & Kipf 2018, "MolGAN: An implicit generative model for small molecular
graphs"; thesis Table 5.1): a Wasserstein GAN with gradient penalty keeps the generated designs diverse, and a
reward network on the non-differentiable fitness pushes them towards good ones; the generator loss mixes the two.

The thesis has no dataset of good robots, so the GAN's "real" data are valid designs drawn uniformly from the
design space (thesis 5.1: "we randomly sample valid robot designs from the design space to train the GAN"):
`problem.random_designs`. The generator is EG-GAN's (same networks, same task encoder, z ~ N(0, I)), so the
methods differ only in how it is trained. Every iteration t (one generator step):

1. draw `tasks` tasks and `samples` noise vectors per task (batch B = tasks x samples, one design per z);
2. `n_critic` critic steps, each on fresh real designs (paired with the iteration's tasks) and fresh generated
   ones: minimise mean C(x_gen, T) - mean C(x_real, T) + gp_weight * mean_x^ (||grad_x^ C(x^, T)|| - 1)^2 over
   the interpolates x^ = e x_real + (1 - e) x_gen, e ~ U(0, 1) per design, the gradient taken with respect to
   the design tensor only (the task is the condition) and its norm over the whole design, as WGAN-GP has it
   (MolGAN's code penalises the norm of each row of its tensors separately and averages). The critic has no
   batch normalisation (it would couple the designs of a batch and void the per-design penalty; MolGAN's critic
   has none either);
3. generator step on fresh draws x: their fitness is asked from the problem (`problem.evaluate`: the same
   learned-fitness model and budget of real rollouts as Fit2form and EG-GAN), and with L_WGAN = -mean C(x, T),
   L_RL = -mean R(x, T) the loss is lam * L_WGAN + (1 - lam) * alpha * L_RL, alpha = |L_WGAN / L_RL| without
   gradient (MolGAN's rescaling of the RL term to the WGAN term's magnitude). The first `wgan_only_iterations`
   iterations use lam = 1 (MolGAN: its first epoch is pure WGAN);
4. `reward_steps` reward-network steps: R(x, T), the critic's structure with a sigmoid output (MolGAN's rewards
   and reward net live in [0, 1]), regressed (MSE) on the fitness of designs generated so far, min-max scaled to
   [0, 1] by the range seen so far (a minimised objective is negated first), each step on `tasks` task groups
   (with their `samples` designs) drawn from all iterations so far. MolGAN fits R on its current batch only,
   generated and real (whose reward it computes for free); here a real design's fitness would spend the same
   budget, and a short run needs its data more than once, so R learns from every generated design seen.

Relaxation of the discrete design: straight-through. A design is drawn per row from the generator's row softmax
p (B, R, C) (`problem.sample_designs`); the critic and R see its one-hot tensor h, and the generator's loss sees
h + p - stopgrad(p): the forward value is the drawn design (so the critic, R and the evaluator all judge the same
design), the gradient flows to p as if h were p. MolGAN's default feeds the plain softmax p to its critic (no
Gumbel noise); we keep the drawn design instead, as its `hard_gumbel_softmax` option does.

Every random choice of iteration t comes from streams seeded by (seed, t) (`iteration_streams`), so the same
config, problem and torch thread count give the same generator to the byte.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from robocompose.eggan.networks import Generator, NetworkConfig, TaskEncoder
from robocompose.eggan.problem import BudgetSpent, EgganProblem, check_problem
from robocompose.eggan.selection import ModelSelection
from robocompose.eggan.train import iteration_streams
from robocompose.io.errors import InputError


@dataclass(frozen=True)
class MolganConfig:
    iterations: int = 100  # generator steps
    tasks: int = 8  # tasks per iteration
    samples: int = 8  # noise vectors (designs) per task; the batch is tasks x samples
    n_critic: int = 5  # critic steps per generator step (MolGAN, WGAN-GP: 5)
    gp_weight: float = 10.0  # weight of the gradient penalty (MolGAN, WGAN-GP: 10)
    lam: float = 0.5  # MolGAN's lambda: weight of the WGAN loss; 1 - lam weighs the (rescaled) reward loss
    wgan_only_iterations: int = 10  # first iterations with lam = 1 (MolGAN: its first epoch)
    reward_steps: int = 5  # reward-network steps per iteration, each on `tasks` earlier task groups of designs
    lr: float = 1e-3  # Adam, all three networks (MolGAN: 1e-3)
    seed: int = 0
    threads: int = 1  # torch threads (results are bit-identical at a fixed thread count)
    validate_every: int = 0  # iterations between validations that select the model kept (selection.py; 0: the last)

    def __post_init__(self):
        if not isinstance(self.validate_every, int) or self.validate_every < 0 or self.validate_every % 10:
            raise InputError(f"validate_every: expected 0 or a multiple of 10 (the log rows), found "
                             f"{self.validate_every!r}")
        for name in ("iterations", "tasks", "samples", "n_critic", "reward_steps", "threads"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise InputError(f"{name}: expected a positive integer, found {value!r}")
        if not isinstance(self.wgan_only_iterations, int) or self.wgan_only_iterations < 0:
            raise InputError(f"wgan_only_iterations: expected an integer >= 0, found {self.wgan_only_iterations!r}")
        if not 0.0 <= self.lam <= 1.0:
            raise InputError(f"lam: expected a weight in [0, 1], found {self.lam!r}")
        if not (self.gp_weight >= 0 and math.isfinite(self.gp_weight)):
            raise InputError(f"gp_weight: expected a finite number >= 0, found {self.gp_weight!r}")
        if not self.lr > 0:
            raise InputError(f"lr: expected a positive learning rate, found {self.lr!r}")


class Critic(nn.Module):
    """C(x, T) -> (B,) unbounded scores (the WGAN critic), or in (0, 1) with `sigmoid` (the reward net R).

    The discriminator's structure (task encoder; MLP of `layers` x `hidden` on [task code, design]) without
    normalisation."""

    def __init__(self, task_shape: tuple[int, ...], design_shape: tuple[int, ...], config: NetworkConfig,
                 sigmoid: bool = False):
        super().__init__()
        self.task = TaskEncoder(tuple(task_shape), config)
        layers: list[nn.Module] = []
        width = self.task.code_size + math.prod(design_shape)
        for _ in range(config.layers):
            layers += [nn.Linear(width, config.hidden), nn.ReLU()]
            width = config.hidden
        self.body = nn.Sequential(*layers, nn.Linear(width, 1), *([nn.Sigmoid()] if sigmoid else []))

    def encode(self, task: torch.Tensor) -> torch.Tensor:
        """(B, *task_shape) -> (B, code)."""
        return self.task(task)

    def forward(self, design: torch.Tensor, task_code: torch.Tensor) -> torch.Tensor:
        """design (B, *design_shape), task code (B, code) -> (B,)."""
        return self.body(torch.cat([task_code, design.flatten(1)], dim=1)).squeeze(1)


def gradient_penalty(critic: nn.Module, real: torch.Tensor, fake: torch.Tensor, task_code: torch.Tensor,
                     generator: torch.Generator | None = None) -> torch.Tensor:
    """WGAN-GP's penalty mean (||grad_x^ C(x^, T)|| - 1)^2 on x^ = e real + (1 - e) fake, e ~ U(0, 1) per design.

    real, fake (B, *design_shape); task_code (B, code), held fixed (the gradient is taken on the design only)."""
    e = torch.rand(len(real), *([1] * (real.dim() - 1)), generator=generator)  # (B, 1, ...)
    mixed = (e * real.detach() + (1 - e) * fake.detach()).requires_grad_(True)  # (B, *design_shape)
    (grad,) = torch.autograd.grad(critic(mixed, task_code).sum(), mixed, create_graph=True)
    return ((grad.flatten(1).norm(dim=1) - 1) ** 2).mean()


def straight_through(sampled_one_hot: torch.Tensor, output: torch.Tensor) -> torch.Tensor:
    """The drawn one-hot designs in the forward pass, the gradient of the row softmax `output` backward."""
    return sampled_one_hot + output - output.detach()


def train_molgan(problem: EgganProblem, network: NetworkConfig, config: MolganConfig, progress: bool = False,
                 select: ModelSelection | None = None) -> tuple[Generator, list[dict]]:
    """Train the conditional MolGAN generator; returns it (eval mode; with `select`, the best validated one) and one
    log row per 10 iterations."""
    from tqdm import tqdm

    check_problem(problem)
    if not problem.discrete or len(problem.objectives) != 1:
        raise ValueError(f"molgan: needs a discrete single-objective problem, {problem.name} is not")
    if not callable(getattr(problem, "random_designs", None)):
        raise ValueError(f"molgan: problem {problem.name} has no random_designs(rng, n) (MolGAN's real data)")
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    generator = Generator(problem.task_shape, problem.design_shape, network)
    critic = Critic(problem.task_shape, problem.design_shape, network)
    reward = Critic(problem.task_shape, problem.design_shape, network, sigmoid=True)
    optimisers = {name: torch.optim.Adam(net.parameters(), lr=config.lr)
                  for name, net in (("g", generator), ("c", critic), ("r", reward))}
    sign = 1.0 if problem.objectives[0].maximise else -1.0
    k, s = config.tasks, config.samples
    # R's data, one entry per task group generated so far: its task tensor, its s designs and their fitness
    seen_tasks: list[torch.Tensor] = []  # (*task_shape) each
    seen_designs: list[torch.Tensor] = []  # (s, *design_shape) each
    seen_fitness: list[torch.Tensor] = []  # (s,) each: sign x fitness (maximised)
    low, high = math.inf, -math.inf  # the range of sign x fitness seen so far (R's targets are scaled by it)
    rows, pending = [], []
    generator.train()

    def draw(codes: torch.Tensor, stream: torch.Generator):
        """One design per z for the (B, code) task codes: the sampled designs and the row softmax (B, R, C)."""
        output = problem.design_head(generator(torch.randn(len(codes), network.latent, generator=stream), codes))
        return problem.sample_designs(output, stream), output

    def log_row(done: int) -> dict:
        """The mean of the pending iterations' values, at `done` completed iterations."""
        return {"iteration": done, **{key: float(np.mean([p[key] for p in pending])) for key in pending[0]},
                "real_evaluations": problem.real_evaluations}

    for iteration in tqdm(range(config.iterations), disable=not progress, desc="molgan", mininterval=5.0):
        rng, stream = iteration_streams(config.seed, iteration)
        tasks = [problem.sample_task(rng) for _ in range(k)]
        task_maps = [problem.encode_task(t) for t in tasks]  # k x (*task_shape)
        task_tensor = torch.stack(task_maps)  # (k, *task_shape)

        # critic steps (WGAN-GP)
        for _ in range(config.n_critic):
            codes = critic.encode(task_tensor).repeat_interleave(s, dim=0)  # (B, code)
            real = problem.design_tensor(problem.random_designs(rng, k * s))  # (B, R, C)
            with torch.no_grad():
                fake = draw(generator.encode(task_tensor).repeat_interleave(s, dim=0), stream)[0].tensor
            penalty = gradient_penalty(critic, real, fake, codes, stream)
            wasserstein = critic(real, codes).mean() - critic(fake, codes).mean()
            optimisers["c"].zero_grad()
            (-wasserstein + config.gp_weight * penalty).backward()
            optimisers["c"].step()

        # generator step: lam * L_WGAN + (1 - lam) * alpha * L_RL on straight-through designs
        sampled, output = draw(generator.encode(task_tensor).repeat_interleave(s, dim=0), stream)
        try:
            fitness = np.concatenate([np.asarray(problem.evaluate(t, sampled.designs[g * s:(g + 1) * s]))[:, 0]
                                      for g, t in enumerate(tasks)])  # (B,)
        except BudgetSpent:  # the critic stepped this iteration; the generator keeps its last completed step
            if pending:
                rows.append(log_row(iteration))
                if select is not None:
                    select.after(rows[-1], generator, final=True)
            break
        relaxed = straight_through(sampled.tensor, output)  # (B, R, C)
        loss_wgan = -critic(relaxed, critic.encode(task_tensor).repeat_interleave(s, dim=0)).mean()
        loss_rl = -reward(relaxed, reward.encode(task_tensor).repeat_interleave(s, dim=0)).mean()
        lam = 1.0 if iteration < config.wgan_only_iterations else config.lam
        alpha = (loss_wgan / loss_rl.clamp(max=-1e-8)).abs().detach()
        loss = lam * loss_wgan + (1 - lam) * alpha * loss_rl
        optimisers["g"].zero_grad()
        loss.backward()
        optimisers["g"].step()

        # reward-network steps: MSE to the min-max scaled fitness of the designs generated so far
        seen_tasks += task_maps
        seen_designs += list(sampled.tensor.detach().view(k, s, *problem.design_shape))
        seen_fitness += list(torch.as_tensor(sign * fitness, dtype=torch.float32).view(k, s))
        low, high = min(low, float(sign * fitness.min())), max(high, float(sign * fitness.max()))
        for _ in range(config.reward_steps):
            groups = rng.choice(len(seen_tasks), size=k, replace=False)  # (k,) earlier task groups
            codes = reward.encode(torch.stack([seen_tasks[g] for g in groups])).repeat_interleave(s, dim=0)
            designs = torch.cat([seen_designs[g] for g in groups])  # (B, R, C)
            targets = (torch.cat([seen_fitness[g] for g in groups]) - low) / max(high - low, 1e-12)  # (B,) in [0, 1]
            mse = ((reward(designs, codes) - targets) ** 2).mean()
            optimisers["r"].zero_grad()
            mse.backward()
            optimisers["r"].step()

        pending.append({"fitness_mean": float(fitness.mean()), "lam": lam,
                        **{name: value.item() for name, value in (("wasserstein", wasserstein), ("gradient_penalty",
                           penalty), ("loss_wgan", loss_wgan), ("loss_rl", loss_rl), ("reward_mse", mse))}})
        if (iteration + 1) % 10 == 0 or iteration + 1 == config.iterations:
            rows.append(log_row(iteration + 1))
            pending = []
            if select is not None:
                select.after(rows[-1], generator, iteration + 1 == config.iterations)
    if select is not None:
        select.restore(generator)
    return generator.eval(), rows
