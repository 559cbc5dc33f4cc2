"""Whitman's DQN baseline (Whitman, Bhirangi, Travers, Choset 2020; thesis Table 5.1), for discrete designs: a
design is built by a sequence of decisions and a Q-network learns the value of each decision.

Decisions. Decision g picks one choice (column) for every row of the problem's `decision_groups[g]` of the
(R, C) design (`robocompose.eggan.problem.SequentialProblem`): on modular robots, one module type per mirrored
port pair, so 3 decisions of 4 and left-right symmetric designs, as in Whitman's code. A problem that declares
no groups is decided one row per step.

State s_t = (task, partial design): the task goes through EG-GAN's task encoder (`networks.TaskEncoder`: for a
height map two 3x3 convolutions of `network.filters` filters and an FC to `network.latent`, Whitman: three 5x5
convolutions of 2 filters and an FC to 10); the partial design is one one-hot row of C per decision (zeros for
decisions not yet made) and a one-hot step indicator of G (G x C + G numbers; Whitman: 4 x 3 + 3 = 15). An MLP
of `layers` x `hidden` ReLU units on [task code, partial design] gives one Q per choice of the next decision.

Episodes. Every iteration draws `tasks` tasks and plays `episodes` episodes on each: at step t the choice is
drawn from softmax(Q(s_t) / T) (Boltzmann exploration), T = max(T0 exp(-n / decay), T_end) after n episodes
(Whitman: T0 = 10, decay 4000 of 15,000 episodes, T_end = 2). The reward is 0 at intermediate steps and, at the
last, the problem's fitness of the finished design (`problem.evaluate`: the same learned-fitness model and
budget of real rollouts as EG-GAN and Fit2form; negated for a minimised objective).

Learning. A replay memory holds the last `replay` episodes (task tensor, choices, reward); every update samples
`batch` episodes and uses all G transitions of each (the task is encoded once per episode, not once per
transition), with the undiscounted one-step target of Whitman's code: y_t = max_a Q_target(s_{t+1}, a) for
t < G - 1 and y_{G-1} = reward; MSE loss, gradients clamped to [-`grad_clamp`, `grad_clamp`], Adam with weight
decay; the target network is a copy of the online network refreshed every `target_every` updates. (Whitman
also halves the learning rate every 10,000 updates after the first 10,000; the default run makes far fewer.)

Answering a task (`best_designs`): the greedy design (argmax Q at every step), then the designs a best-first
search over partial designs reaches next, each partial design scored by the Q of the decision that made it (the
learned value as a search heuristic, as the thesis describes its DQN baseline): k distinct designs with their
predicted fitness, no simulation, no randomness.

Every random choice of iteration t comes from streams seeded with (seed, t) (`train.iteration_streams`), so the
same problem, networks and config give the same bytes of the saved model.
"""

from __future__ import annotations

import copy
import heapq
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from robocompose.eggan.networks import NetworkConfig, TaskEncoder
from robocompose.eggan.problem import (
    BudgetSpent,
    Design,
    SequentialProblem,
    Task,
    check_problem,
    decision_groups_of,
)
from robocompose.eggan.selection import ModelSelection
from robocompose.eggan.storage import load_model, save_model
from robocompose.eggan.train import iteration_streams
from robocompose.io.errors import InputError


@dataclass(frozen=True)
class DQNConfig:
    """Training settings (Whitman's values in brackets where ours differ)."""

    iterations: int = 100  # acting rounds
    tasks: int = 8  # tasks per iteration (one `problem.evaluate` call each)
    episodes: int = 8  # Boltzmann episodes (finished designs) per task per iteration
    updates: int = 4  # optimisation steps per iteration, once `start` episodes are stored
    batch: int = 64  # episodes per optimisation step, all their decisions used [250 transitions]
    replay: int = 2000  # replay memory, in episodes [5000 transitions]
    start: int = 256  # episodes stored before the first optimisation step
    target_every: int = 25  # optimisation steps between target-network refreshes [100]
    temperature_start: float = 10.0  # T0 of the Boltzmann schedule
    temperature_end: float = 2.0  # the floor T_end
    temperature_decay: float = 1700.0  # episodes per e-fold of T [4000 of 15,000 episodes; scaled to 6400]
    hidden: int = 200  # width of the Q-network's hidden layers
    layers: int = 4  # hidden layers of the Q-network's MLP
    lr: float = 1e-3  # Adam [5e-5 over 15,000 episodes; raised for the short default]
    weight_decay: float = 1e-4
    grad_clamp: float = 1.0  # every gradient component clamped to [-grad_clamp, grad_clamp]
    seed: int = 0
    threads: int = 1  # torch threads (results are bit-identical at a fixed thread count)
    validate_every: int = 0  # iterations between validations that select the model kept (selection.py; 0: the last)

    def __post_init__(self):
        if not isinstance(self.validate_every, int) or self.validate_every < 0 or self.validate_every % 10:
            raise InputError(f"validate_every: expected 0 or a multiple of 10 (the log rows), found "
                             f"{self.validate_every!r}")
        for name in ("iterations", "tasks", "episodes", "updates", "batch", "replay", "start", "target_every",
                     "hidden", "layers", "threads"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise InputError(f"{name}: expected a positive integer, found {value!r}")
        if not isinstance(self.seed, int):
            raise InputError(f"seed: expected an integer, found {self.seed!r}")
        for name in ("temperature_end", "temperature_decay", "lr", "grad_clamp"):
            if not getattr(self, name) > 0:
                raise InputError(f"{name}: expected a positive number, found {getattr(self, name)!r}")
        if not self.temperature_start >= self.temperature_end:
            raise InputError(f"temperature_start: expected >= temperature_end ({self.temperature_end}), found "
                             f"{self.temperature_start!r}")
        if not self.weight_decay >= 0:
            raise InputError(f"weight_decay: expected >= 0, found {self.weight_decay!r}")
        if self.start > self.replay:
            raise InputError(f"start: expected <= replay ({self.replay}, the memory's size), found {self.start!r}")

    def temperature(self, episodes: int) -> float:
        """The Boltzmann temperature after `episodes` episodes."""
        return max(self.temperature_start * math.exp(-episodes / self.temperature_decay), self.temperature_end)


class QNetwork(nn.Module):
    """Q(task, partial design) -> one value per choice of the next decision (see the module docstring)."""

    def __init__(self, task_shape: tuple[int, ...], decisions: int, choices: int, network: NetworkConfig,
                 hidden: int, layers: int):
        super().__init__()
        self.task_shape, self.decisions, self.choices = tuple(task_shape), decisions, choices
        self.network, self.hidden, self.layers = network, hidden, layers
        self.task = TaskEncoder(self.task_shape, network)
        body: list[nn.Module] = []
        width = self.task.code_size + decisions * choices + decisions
        for _ in range(layers):
            body += [nn.Linear(width, hidden), nn.ReLU()]
            width = hidden
        self.body = nn.Sequential(*body, nn.Linear(width, choices))

    def encode(self, task: torch.Tensor) -> torch.Tensor:
        """(B, *task_shape) -> (B, code)."""
        return self.task(task)

    def forward(self, code: torch.Tensor, partial: torch.Tensor) -> torch.Tensor:
        """task code (B, code), partial design (B, G*C + G) -> Q (B, C)."""
        return self.body(torch.cat([code, partial], dim=1))

    def partial(self, choices: torch.Tensor, step: int) -> torch.Tensor:
        """(B, >= step) choices -> (B, G*C + G): the first `step` decisions one-hot, the step indicator."""
        made = torch.zeros(len(choices), self.decisions, self.choices)  # (B, G, C)
        if step:
            made[:, :step] = F.one_hot(choices[:, :step], self.choices).float()
        indicator = torch.zeros(len(choices), self.decisions)  # (B, G)
        indicator[:, step] = 1.0
        return torch.cat([made.flatten(1), indicator], dim=1)


class Replay:
    """A ring buffer of the last `capacity` episodes: task tensors, choices, rewards."""

    def __init__(self, capacity: int, task_shape: tuple[int, ...], decisions: int):
        self.tasks = torch.zeros(capacity, *task_shape)  # (N, *task_shape)
        self.choices = torch.zeros(capacity, decisions, dtype=torch.int64)  # (N, G)
        self.rewards = torch.zeros(capacity)  # (N,)
        self.capacity, self.size, self.next = capacity, 0, 0

    def add(self, tasks: torch.Tensor, choices: torch.Tensor, rewards: torch.Tensor) -> None:
        slots = (self.next + torch.arange(len(choices))) % self.capacity
        self.tasks[slots], self.choices[slots], self.rewards[slots] = tasks, choices, rewards
        self.next = int(slots[-1] + 1) % self.capacity
        self.size = min(self.size + len(choices), self.capacity)

    def sample(self, rng: np.random.Generator, n: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        index = torch.as_tensor(rng.integers(self.size, size=n))
        return self.tasks[index], self.choices[index], self.rewards[index]


def td_loss(online: QNetwork, target: QNetwork, tasks: torch.Tensor, choices: torch.Tensor,
            rewards: torch.Tensor) -> torch.Tensor:
    """Mean squared TD error over every decision of E episodes: tasks (E, ...), choices (E, G), rewards (E,)."""
    e, g = choices.shape
    states = torch.cat([online.partial(choices, t) for t in range(g)])  # (G*E, S), row t*E + i: episode i, step t
    q = online(online.encode(tasks).repeat(g, 1), states).gather(1, choices.T.reshape(-1, 1)).squeeze(1)  # (G*E,)
    with torch.no_grad():
        targets = torch.empty(g, e)
        targets[g - 1] = rewards  # the finished design's fitness
        if g > 1:  # no discount, no intermediate reward: y_t = max_a Q_target(s_{t+1}, a)
            following = torch.cat([online.partial(choices, t) for t in range(1, g)])  # ((G-1)*E, S)
            targets[:g - 1] = target(target.encode(tasks).repeat(g - 1, 1), following).max(dim=1).values.view(g - 1, e)
    return F.mse_loss(q, targets.flatten())


def choices_to_rows(choices: np.ndarray, groups: tuple[tuple[int, ...], ...]) -> np.ndarray:
    """(B, G) decisions -> (B, R) choice per row of the design: decision g sets every row of groups[g]."""
    rows = np.empty((len(choices), sum(len(group) for group in groups)), dtype=np.int64)
    for g, group in enumerate(groups):
        rows[:, list(group)] = np.asarray(choices)[:, g:g + 1]
    return rows


@torch.no_grad()
def boltzmann_episodes(net: QNetwork, tasks: torch.Tensor, temperature: float,
                       stream: torch.Generator) -> torch.Tensor:
    """One episode per task row (B, *task_shape): choices (B, G) drawn from softmax(Q / temperature) per step."""
    code = net.encode(tasks)  # (B, code)
    choices = torch.zeros(len(tasks), net.decisions, dtype=torch.int64)  # (B, G)
    for t in range(net.decisions):
        probabilities = torch.softmax(net(code, net.partial(choices, t)) / temperature, dim=1)  # (B, C)
        choices[:, t] = torch.multinomial(probabilities, 1, generator=stream).squeeze(1)
    return choices


def train_dqn(problem: SequentialProblem, network: NetworkConfig, config: DQNConfig, progress: bool = False,
              select: ModelSelection | None = None) -> tuple[QNetwork, list[dict]]:
    """Train the Q-network; returns it (eval mode; with `select`, the best validated one) and one log row per 10
    iterations."""
    from tqdm import tqdm

    check_problem(problem)
    if not problem.discrete or len(problem.objectives) != 1 or len(problem.design_shape) != 2:
        raise ValueError(f"dqn: needs a discrete single-objective problem with (rows, choices) designs, "
                         f"{problem.name} is not")
    groups = decision_groups_of(problem)
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    online = QNetwork(problem.task_shape, len(groups), problem.design_shape[1], network, config.hidden,
                      config.layers)
    target = copy.deepcopy(online).requires_grad_(False)
    optimiser = torch.optim.Adam(online.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    memory = Replay(config.replay, problem.task_shape, len(groups))
    sign = 1.0 if problem.objectives[0].maximise else -1.0
    k, e = config.tasks, config.episodes
    rows, fitness_seen, losses = [], [], []
    played = updates = 0
    def log_row(done: int, temperature: float) -> dict:
        return {"iteration": done, "episodes": played, "temperature": temperature,
                "fitness_mean": float(np.mean(fitness_seen)),
                "td_loss": float(np.mean(losses)) if losses else float("nan"), "updates": updates,
                "real_evaluations": problem.real_evaluations}

    for iteration in tqdm(range(config.iterations), disable=not progress, desc="dqn", mininterval=5.0):
        rng, stream = iteration_streams(config.seed, iteration)
        temperature = config.temperature(played)
        tasks = [problem.sample_task(rng) for _ in range(k)]
        task_tensor = torch.stack([problem.encode_task(task) for task in tasks]).repeat_interleave(e, dim=0)  # (k*e,..)
        choices = boltzmann_episodes(online, task_tensor, temperature, stream)  # (k*e, G)
        designs = problem.designs_from_choices(choices_to_rows(choices.numpy(), groups))
        try:
            fitness = np.concatenate([np.asarray(problem.evaluate(task, designs[i * e:(i + 1) * e]))[:, 0]
                                      for i, task in enumerate(tasks)])  # (k*e,)
        except BudgetSpent:
            if fitness_seen:
                rows.append(log_row(iteration, temperature))
                if select is not None:
                    select.after(rows[-1], online, final=True)
            break
        memory.add(task_tensor, choices, torch.as_tensor(sign * fitness, dtype=torch.float32))
        played += k * e
        fitness_seen.append(float(fitness.mean()))
        for _ in range(config.updates if memory.size >= config.start else 0):
            loss = td_loss(online, target, *memory.sample(rng, config.batch))
            optimiser.zero_grad()
            loss.backward()
            for parameter in online.parameters():
                parameter.grad.clamp_(-config.grad_clamp, config.grad_clamp)
            optimiser.step()
            losses.append(float(loss.detach()))
            updates += 1
            if updates % config.target_every == 0:
                target.load_state_dict(online.state_dict())
        if (iteration + 1) % 10 == 0 or iteration + 1 == config.iterations:
            rows.append(log_row(iteration + 1, temperature))
            fitness_seen, losses = [], []
            if select is not None:
                select.after(rows[-1], online, iteration + 1 == config.iterations)
    if select is not None:
        select.restore(online)
    return online.eval(), rows


@torch.no_grad()
def best_designs(net: QNetwork, problem: SequentialProblem, task: Task, k: int) -> list[tuple[Design, float]]:
    """k distinct designs for `task` and their predicted fitness (the Q of their last decision): the greedy design,
    then best-first search over partial designs by the Q of the decision that made each (module docstring)."""
    if k < 1:
        raise InputError(f"k: expected a positive number of designs, found {k}")
    groups, g = decision_groups_of(problem), net.decisions
    sign = 1.0 if problem.objectives[0].maximise else -1.0
    code = net.encode(problem.encode_task(task).unsqueeze(0))  # (1, code)

    def q_values(prefix: tuple[int, ...]) -> list[float]:
        return net(code, net.partial(torch.tensor([prefix + (0,) * (g - len(prefix))]), len(prefix)))[0].tolist()

    greedy: tuple[int, ...] = ()
    while len(greedy) < g:
        values = q_values(greedy)
        greedy += (int(np.argmax(values)),)
    found = [(greedy, values[greedy[-1]])]
    frontier = [(-value, (choice,)) for choice, value in enumerate(q_values(()))]  # max-heap by Q, ties by choices
    heapq.heapify(frontier)
    while frontier and len(found) < k:
        negative, prefix = heapq.heappop(frontier)
        if len(prefix) < g:
            for choice, value in enumerate(q_values(prefix)):
                heapq.heappush(frontier, (-value, prefix + (choice,)))
        elif prefix != greedy:
            found.append((prefix, -negative))
    designs = problem.designs_from_choices(choices_to_rows(np.array([f for f, _ in found]), groups))
    return [(design, sign * value) for design, (_, value) in zip(designs, found, strict=True)]


# --- the Q-network as a file: weights, sizes and provenance (behind the checksum header of `eggan.storage`) ---

def save_dqn(net: QNetwork, problem: SequentialProblem, path: str | Path, meta: dict) -> Path:
    """Write the Q-network's weights and sizes to `path` (torch) and `meta` + provenance beside it (`.json`)."""
    from robocompose.io.provenance import code_digest

    info = {"problem": problem.name, "task_shape": list(net.task_shape), "design_shape": list(problem.design_shape),
            "decision_groups": [list(group) for group in decision_groups_of(problem)],
            "network": asdict(net.network), "hidden": net.hidden, "layers": net.layers,
            "model_code": code_digest(__name__), **meta}
    return save_model(info, net.state_dict(), path)


def load_dqn(path: str | Path, problem: SequentialProblem) -> tuple[QNetwork, dict]:
    """A saved Q-network for `problem`, in eval mode, and its info; a clear error if it does not fit."""
    info, state = load_model(path, "a DQN")
    groups = [list(group) for group in decision_groups_of(problem)]
    found = tuple(info.get(key) for key in ("problem", "task_shape", "design_shape", "decision_groups"))
    if found != (problem.name, list(problem.task_shape), list(problem.design_shape), groups):
        raise InputError(f"{path}: a DQN for {found[0]} {found[1]} -> {found[2]} (decisions {found[3]}), not for "
                         f"{problem.name} {list(problem.task_shape)} -> {list(problem.design_shape)} "
                         f"(decisions {groups})")
    net = QNetwork(problem.task_shape, len(groups), problem.design_shape[1], NetworkConfig(**info["network"]),
                   info["hidden"], info["layers"])
    net.load_state_dict(state)
    return net.eval(), info
