"""Training EG-GAN (thesis Algorithm 1) on any `EgganProblem`, with checkpoints that resume exactly.

Every iteration t:
1. draw `tasks` tasks T from the problem's task distribution and B / tasks noise vectors z ~ N(0, I_P) each;
2. X_gen: one design per z drawn from the generator's output X~ = G(z, T) (for a continuous problem the
   output is the design), evaluated on its T;
3. X_pop = EVO(X_gen, T) per task: the problem's evolution-guided data creation (`config.evolution` for
   `config.evolution_steps` steps: deterministic crowding = EG-GAN-crowding, Alg. 2; a classic GA
   generation = EG-GAN; NSGA-II for a multi-objective problem, Alg. 3);
4. generator step. Discrete designs, conditional BGAN (eq. 4.2, in the form of Hjelm et al.'s code): for each
   z draw M designs x_m from X~, weight them by the softmax over the M of the discriminator's logits
   log D/(1-D) (no gradient through the weights), loss = -mean_z sum_m w_m log P_theta(x_m | z, T).
   Continuous designs: the conditional GAN loss log(1 - D(G(z, T), T)) (eq. 4.1), minimised;
5. discriminator step: cross-entropy with X_pop labelled 1 and X_gen labelled 0 (eq. 4.3), one batch.

Elite archive (`archive` K > 0, ours, single-objective problems): per training task the K fittest distinct designs
found so far (generated or evolved) are kept with their fitness, and step 3 evolves X_gen together with the task's
archive, X_pop being the `per` fittest of the evolved union. Without it X_pop is a few evolution steps from X_gen,
so once the generator concentrates X_pop is mostly X_gen again (issue 46: the evolved share fell from 0.55 to
0.085 and the discriminator to chance). An archived design's fitness is the one recorded when it was evaluated:
it is not asked again (on exact tables a re-read would cost no look-up anyway; a problem that counts every
evaluation counts only the evolution's children), so the budget is counted as without the archive.

Early stopping (`best_by`, ours): with a `validate` callback, the generator weights of the best value of that
validation score so far (maximised) are kept beside the running ones; the trained generator returned is the best
one, and `Trained.best_iteration` (and each validated log row's `best_iteration`) says where it was.

Several tasks per iteration (the thesis draws one): each task's designs are evolved as their own population,
and the networks' layer normalisation keeps every row a function of its own (z, task) (networks.py says why
not batch norm). `tasks: 1` is the thesis's literal setting.

Logged per row: both losses, the discriminator's mean output on X_pop and X_gen and its accuracy (X_pop above
1/2, X_gen below; 0.5 is chance: a discriminator that cannot tell evolved designs from generated ones gives the
generator no signal), the share of X_pop that evolution made new (designs not among that task's X_gen: the rest
stand in both halves of D's batch, so even a perfect discriminator is right on them only half the time, and
its accuracy is at most (1 + pop_new) / 2), the distinct designs of a task's draws, each objective's mean and
best. With a
`validate` callback (e.g. the modular problem's validation terrains) every `validate_every` iterations the row
also holds its scores: the validation curve that says whether training has flattened. A problem whose budget
of evaluations runs out (`BudgetSpent`) ends the run after the last completed iteration; `Trained.stopped`
says where.

Every random choice of iteration t comes from generators seeded with (seed, t), and a checkpoint holds the
networks, both optimisers, the log and the problem's own state (`problem.state_dict()`: a surrogate, its
data, the evaluation counters), so a killed run resumes to the same bytes. The checkpoint key covers the
training settings (not the bookkeeping: iterations, log and checkpoint cadence), the network sizes, the
problem's key (its settings, data and code) and the code digest of this package, storage and fan-out excluded
(`provenance.INFRASTRUCTURE`: they keep results without shaping them, so changing them re-keys no run).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch
import torch.nn.functional as F

from robocompose.eggan.networks import Discriminator, Generator, NetworkConfig
from robocompose.eggan.problem import BudgetSpent, EgganProblem, check_problem
from robocompose.io import McapWriter, atomic_write_text
from robocompose.io.checkpoint import load_checkpoint, save_checkpoint
from robocompose.io.errors import InputError
from robocompose.io.provenance import INFRASTRUCTURE, code_digest


@dataclass(frozen=True)
class TrainConfig:
    """Algorithm 1's settings."""

    iterations: int = 1000  # training iterations (one task each)
    batch: int = 64  # B: noise vectors per iteration = |X_gen| = |X_pop|
    tasks: int = 8  # tasks per iteration, batch / tasks noise vectors (an even number: crowding pairs) each
    samples: int = 20  # M: designs drawn per z for the BGAN loss (Hjelm et al.: 20)
    evolution: str = "crowding"  # the problem's evolution method: "crowding" (EG-GAN-crowding), "ga" (EG-GAN)
    evolution_steps: int = 1  # n: evolution steps per iteration (the group's code: 1)
    lr_generator: float = 1e-4  # Adam (BGAN code: 1e-4, beta1 0.5)
    lr_discriminator: float = 1e-4
    beta1: float = 0.5
    seed: int = 0
    threads: int = 1  # torch threads (results are bit-identical at a fixed thread count)
    log_every: int = 10  # iterations per logged row (means over the rows' iterations)
    validate_every: int = 0  # iterations between validation scores (a multiple of log_every; 0: none)
    checkpoint_every: int = 50  # iterations between checkpoints (a multiple of log_every)
    archive: int = 0  # K: fittest distinct designs kept per training task and evolved with X_gen (0: none, thesis)
    best_by: str = ""  # a validation score (maximised) whose best generator is kept (early stopping); "": the last

    def __post_init__(self):
        for name in ("iterations", "batch", "samples", "evolution_steps", "threads", "log_every",
                     "checkpoint_every"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < (0 if name in ("iterations", "evolution_steps") else 1):
                raise InputError(f"{name}: expected a positive integer, found {value!r}")
        if self.tasks < 1 or self.batch % self.tasks or (self.batch // self.tasks) % 2:
            raise InputError(f"batch {self.batch} / tasks {self.tasks}: expected an even number of noise vectors "
                             "per task (the evolution pairs parents)")
        if not isinstance(self.validate_every, int) or self.validate_every < 0 or self.validate_every % self.log_every:
            raise InputError(f"validate_every: expected 0 or a multiple of log_every ({self.log_every}), found "
                             f"{self.validate_every!r}")
        if self.checkpoint_every % self.log_every:
            raise InputError(f"checkpoint_every ({self.checkpoint_every}) must be a multiple of log_every "
                             f"({self.log_every}): logged rows must not straddle a resume")
        for name in ("lr_generator", "lr_discriminator"):
            if not getattr(self, name) > 0:
                raise InputError(f"{name}: expected a positive learning rate, found {getattr(self, name)}")
        if not isinstance(self.archive, int) or isinstance(self.archive, bool) or self.archive < 0 or self.archive % 2:
            raise InputError(f"archive: expected 0 or a positive even number of designs per task (the evolution pairs "
                             f"parents), found {self.archive!r}")
        if not isinstance(self.best_by, str) or (self.best_by and not self.validate_every):
            raise InputError(f"best_by: expected \"\" or a validation score with validate_every > 0, found "
                             f"{self.best_by!r} (validate_every {self.validate_every})")


# Settings that do not change what iteration t computes: a finished run continues when only these grow.
BOOKKEEPING = ("iterations", "log_every", "checkpoint_every", "validate_every")


@dataclass
class Trained:
    """A trained (or resumed) EG-GAN: both networks, the log rows, and the run's key."""

    generator: Generator
    discriminator: Discriminator
    rows: list[dict]
    key: str
    network: NetworkConfig
    config: TrainConfig
    stopped: int | None = None  # the iterations completed when the problem's budget ran out (None: it did not)
    best_iteration: int | None = None  # with `best_by`: the iteration whose generator this is (None: the last)


def run_key(problem: EgganProblem, network: NetworkConfig, config: TrainConfig) -> str:
    """What a checkpoint must match to be resumed (see the module docstring)."""
    settings = {k: v for k, v in dataclasses.asdict(config).items() if k not in BOOKKEEPING}
    text = json.dumps([settings, dataclasses.asdict(network), problem.key(),
                       code_digest(__name__, exclude=INFRASTRUCTURE)], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def iteration_streams(seed: int, iteration: int) -> tuple[np.random.Generator, torch.Generator]:
    """The numpy and torch random streams of one iteration: functions of (seed, iteration) only."""
    rng = np.random.default_rng([seed, iteration, 4101])
    state = np.random.SeedSequence([seed, iteration, 4102]).generate_state(1, dtype=np.uint64)[0]
    return rng, torch.Generator().manual_seed(int(state) & 0x7FFF_FFFF_FFFF_FFFF)


def bgan_generator_loss(d_logits: torch.Tensor, log_prob: torch.Tensor) -> torch.Tensor:
    """Conditional BGAN loss (eq. 4.2): d_logits, log_prob (B, M) -> -mean_b sum_m softmax_m(d) log P."""
    weights = torch.softmax(d_logits.detach(), dim=1)  # (B, M): normalised importance weights, no gradient
    return -(weights * log_prob).sum(dim=1).mean()


def gan_generator_loss(d_logits: torch.Tensor) -> torch.Tensor:
    """Conditional GAN loss (eq. 4.1) log(1 - D(G(z, T), T)), minimised; log(1 - sigmoid(a)) = -softplus(a)."""
    return -F.softplus(d_logits).mean()


def discriminator_loss(real_logits: torch.Tensor, fake_logits: torch.Tensor) -> torch.Tensor:
    """Eq. 4.3: -[log D(X_pop) + log(1 - D(X_gen))], averaged over both halves of the batch."""
    logits = torch.cat([real_logits, fake_logits])
    labels = torch.cat([torch.ones_like(real_logits), torch.zeros_like(fake_logits)])
    return F.binary_cross_entropy_with_logits(logits, labels)


def _objective_stats(prefix: str, problem: EgganProblem, values: np.ndarray) -> dict[str, float]:
    """Mean and best of each objective of a batch (best = max if maximised, else min)."""
    stats = {}
    for k, objective in enumerate(problem.objectives):
        column = values[:, k]
        stats[f"{prefix}_{objective.name}_mean"] = float(column.mean())
        stats[f"{prefix}_{objective.name}_best"] = float(column.max() if objective.maximise else column.min())
    return stats


Archive = dict  # task -> [(design, objective values)], fittest first: a task's elite archive (`TrainConfig.archive`)


def evolve_with_archive(problem: EgganProblem, task, designs: list, values: np.ndarray, archive: Archive,
                        config: TrainConfig, rng: np.random.Generator) -> tuple[list, np.ndarray]:
    """X_pop of one task and its (per, 1) fitness: evolution on X_gen and the task's archive (an even number of its
    fittest), the `per` fittest of the result; the archive then keeps the K fittest distinct designs seen (ties:
    the earlier kept first, so the archive is a function of the run's draws)."""
    per, elite = len(designs), archive.get(task, [])
    elite = elite[:len(elite) - len(elite) % 2]  # crowding and the GA pair parents
    parents = designs + [d for d, _ in elite]
    fitness = np.concatenate([values, np.array([v for _, v in elite], dtype=np.float64).reshape(-1, 1)])
    evolved, evolved_values = problem.evolve(task, parents, fitness, config.evolution, config.evolution_steps, rng)
    evolved_values = np.asarray(evolved_values, dtype=np.float64).reshape(len(evolved), 1)
    fittest = np.argsort(-evolved_values[:, 0], kind="stable")[:per]
    seen: dict[str, tuple] = {}
    for design, value in [*archive.get(task, []), *zip(designs, values.tolist(), strict=True),
                          *zip(evolved, evolved_values.tolist(), strict=True)]:
        seen.setdefault(problem.design_id(design), (design, [float(v) for v in value]))
    kept = sorted(seen.values(), key=lambda item: -item[1][0])  # stable: earlier first among equals
    archive[task] = kept[:config.archive]
    return [evolved[i] for i in fittest], evolved_values[fittest]


def train_step(problem: EgganProblem, generator: Generator, discriminator: Discriminator,
               opt_g: torch.optim.Optimizer, opt_d: torch.optim.Optimizer, config: TrainConfig,
               iteration: int, archive: Archive | None = None) -> dict[str, float]:
    """One iteration of Algorithm 1 on `config.tasks` tasks of `config.batch // config.tasks` z each; with
    `config.archive`, X_pop is evolved with each task's `archive` (which the step updates)."""
    rng, stream = iteration_streams(config.seed, iteration)
    k, per, m = config.tasks, config.batch // config.tasks, config.samples
    b = k * per
    tasks = [problem.sample_task(rng) for _ in range(k)]
    task_tensor = torch.stack([problem.encode_task(task) for task in tasks])  # (k, *task_shape)
    z = torch.randn(b, generator.config.latent, generator=stream)  # (B, P); rows g*per .. (g+1)*per - 1: task g
    generator.train()
    discriminator.train()
    g_code = generator.encode(task_tensor).repeat_interleave(per, dim=0)  # (B, code)
    output = problem.design_head(generator(z, g_code))  # (B, *design_shape)

    with torch.no_grad():
        generated = problem.sample_designs(output.detach(), stream)  # X_gen
    gen_objectives, population, pop_objectives, new = [], [], [], 0
    for g, task in enumerate(tasks):
        designs = list(generated.designs[g * per:(g + 1) * per])
        values = np.asarray(problem.evaluate(task, designs), dtype=np.float64).reshape(per, -1)
        if config.archive:
            evolved, evolved_values = evolve_with_archive(problem, task, designs, values, archive, config, rng)
        else:
            evolved, evolved_values = problem.evolve(task, designs, values, config.evolution, config.evolution_steps,
                                                     rng)  # X_pop of this task
        drawn = {problem.design_id(d) for d in designs}
        new += sum(problem.design_id(d) not in drawn for d in evolved)
        gen_objectives.append(values)
        population += list(evolved)
        pop_objectives.append(np.asarray(evolved_values, dtype=np.float64).reshape(per, -1))
    gen_objectives, pop_objectives = np.concatenate(gen_objectives), np.concatenate(pop_objectives)  # (B, K)

    d_code = discriminator.encode(task_tensor)  # (k, code)
    if problem.discrete:
        repeated = output.repeat_interleave(m, dim=0)  # (B*M, *design_shape), row b*M + j belongs to z_b
        drawn = problem.sample_designs(repeated, stream)
        with torch.no_grad():
            d_logits = discriminator(drawn.tensor, d_code.repeat_interleave(per * m, dim=0)).view(b, m)
        loss_g = bgan_generator_loss(d_logits, drawn.log_prob.view(b, m))
    else:
        loss_g = gan_generator_loss(discriminator(output, d_code.repeat_interleave(per, dim=0)))
    opt_g.zero_grad()
    loss_g.backward()
    opt_g.step()

    real = problem.design_tensor(population)  # (B, *design_shape)
    codes = discriminator.encode(task_tensor).repeat_interleave(per, dim=0)  # (B, code)
    logits = discriminator(torch.cat([real, generated.tensor.detach()]), torch.cat([codes, codes]))  # (2B,)
    loss_d = discriminator_loss(logits[:b], logits[b:])
    opt_d.zero_grad()
    loss_d.backward()
    opt_d.step()

    with torch.no_grad():
        row = {"loss_g": float(loss_g), "loss_d": float(loss_d),
               "d_pop": float(torch.sigmoid(logits[:b]).mean()), "d_gen": float(torch.sigmoid(logits[b:]).mean()),
               "d_accuracy": float(((logits[:b] > 0).sum() + (logits[b:] <= 0).sum()) / (2 * b)),
               "gen_distinct": len({problem.design_id(d) for d in generated.designs[:per]}),
               "pop_new": new / b}
    row.update(_objective_stats("gen", problem, gen_objectives))
    row.update(_objective_stats("pop", problem, pop_objectives))
    return row


def write_logs(rows: list[dict], csv_path: Path | None, mcap_path: Path | None, topic: str) -> None:
    """The training curves as a CSV (DVC plots) and an MCAP log (one message per row on `topic`)."""
    if csv_path is not None:
        atomic_write_text(csv_path, pd.DataFrame(rows).to_csv(index=False, float_format="%.6g"))
    if mcap_path is not None:
        with McapWriter(mcap_path) as log:
            for row in rows:
                log.scalars(topic, float(row["iteration"]),
                            {k: v for k, v in row.items() if k != "iteration" and not math.isnan(v)})



Validate = Callable[[Generator], dict[str, float]]  # generator -> validation scores (must not change its weights)


def train(problem: EgganProblem, network: NetworkConfig, config: TrainConfig, checkpoint: Path | None = None,
          csv_path: Path | None = None, mcap_path: Path | None = None, progress: bool = False,
          validate: Validate | None = None) -> Trained:
    """Run Algorithm 1 for `config.iterations` iterations (or until the problem's budget is spent), resuming from
    `checkpoint` if it holds this run; `validate` scores the generator every `config.validate_every` iterations."""
    check_problem(problem)
    if config.evolution not in problem.evolution_methods:
        raise InputError(f"evolution: problem {problem.name} supports {list(problem.evolution_methods)}, "
                         f"found {config.evolution!r}")
    if config.archive and (len(problem.objectives) != 1 or not problem.objectives[0].maximise):
        raise InputError(f"archive: expected 0 for problem {problem.name} (an archive keeps the fittest designs of one "
                         f"maximised objective), found {config.archive}")
    if config.best_by and validate is None:
        raise InputError(f"best_by: {config.best_by!r} needs a validation callback (problem {problem.name} gives "
                         "none here)")
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    generator = Generator(problem.task_shape, problem.design_shape, network)
    discriminator = Discriminator(problem.task_shape, problem.design_shape, network)
    opt_g = torch.optim.Adam(generator.parameters(), lr=config.lr_generator, betas=(config.beta1, 0.999))
    opt_d = torch.optim.Adam(discriminator.parameters(), lr=config.lr_discriminator, betas=(config.beta1, 0.999))
    key = run_key(problem, network, config)
    start, rows, stopped = 0, [], None
    archive: Archive = {}
    best: dict | None = None  # with best_by: {"iteration", "score", "generator": its weights}
    saved = load_checkpoint(checkpoint, key)  # None unless it holds this run (a damaged one is moved aside)
    if saved is not None and saved["iteration"] > config.iterations:
        print(f"{checkpoint} is at iteration {saved['iteration']}, past this run's {config.iterations}: starting "
              "afresh", flush=True)
        saved = None
    if saved is not None:
        generator.load_state_dict(saved["generator"])
        discriminator.load_state_dict(saved["discriminator"])
        opt_g.load_state_dict(saved["opt_g"])
        opt_d.load_state_dict(saved["opt_d"])
        problem.load_state_dict(saved["problem"])
        start, rows, stopped = saved["iteration"], saved["rows"], saved.get("stopped")
        archive = {task: [(design, list(values)) for design, values in kept] for task, kept in saved["archive"]}
        best = saved["best"]
        print(f"resuming from {checkpoint} at iteration {start}", flush=True)

    from tqdm import tqdm

    topic = f"/eggan/{problem.name}/train"
    pending: list[dict] = []
    bar = tqdm(total=config.iterations, initial=start, disable=not progress, desc=f"eggan {problem.name}",
               mininterval=5.0)
    done = start
    for iteration in range(start, config.iterations if stopped is None else start):
        try:
            pending.append(train_step(problem, generator, discriminator, opt_g, opt_d, config, iteration, archive))
        except BudgetSpent as spent:
            stopped = iteration
            print(f"eggan {problem.name}: budget spent at iteration {iteration} ({spent})", flush=True)
        else:
            done = iteration + 1
        final = done == config.iterations or stopped is not None
        if pending and (done % config.log_every == 0 or final):
            row = {"iteration": done, **pd.DataFrame(pending).mean().to_dict(),
                   "real_evaluations": problem.real_evaluations}
            if validate is not None and config.validate_every and (done % config.validate_every == 0
                                                                   or final):
                row.update(validate(generator))
                if config.best_by:
                    best = _keep_best(best, row, generator, config.best_by)
                    row["best_iteration"] = best["iteration"]
            rows.append(row)
            pending = []
            bar.set_postfix(loss_d=f"{row['loss_d']:.3f}", real=row["real_evaluations"])
        if checkpoint is not None and (done % config.checkpoint_every == 0 or final) and done > start:
            save_checkpoint(checkpoint, key, {
                "iteration": done, "generator": generator.state_dict(), "discriminator": discriminator.state_dict(),
                "opt_g": opt_g.state_dict(), "opt_d": opt_d.state_dict(), "problem": problem.state_dict(),
                "rows": rows, "stopped": stopped, "best": best,
                "archive": [[task, [[design, values] for design, values in kept]] for task, kept in archive.items()]})
            write_logs(rows, csv_path, mcap_path, topic)
        bar.update(1)
        if stopped is not None:
            break
    bar.close()
    if done == start or checkpoint is None:
        write_logs(rows, csv_path, mcap_path, topic)
    if best is not None:
        generator.load_state_dict(best["generator"])
        print(f"eggan {problem.name}: keeping the generator of iteration {best['iteration']} ({config.best_by} "
              f"{best['score']:.4f})", flush=True)
    return Trained(generator.eval(), discriminator.eval(), rows, key, network, config, stopped,
                   None if best is None else best["iteration"])


def _keep_best(best: dict | None, row: dict, generator: Generator, score: str) -> dict:
    """The best validated generator so far: this row's, if its `score` beats the kept one's (ties keep the
    earlier), else the kept one."""
    if score not in row:
        raise InputError(f"best_by: expected one of the validation scores {sorted(k for k in row if k != 'iteration')}"
                         f", found {score!r}")
    if best is not None and not row[score] > best["score"]:
        return best
    return {"iteration": int(row["iteration"]), "score": float(row[score]),
            "generator": {k: v.detach().clone() for k, v in generator.state_dict().items()}}
