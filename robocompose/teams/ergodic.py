"""Ergodic coverage cost of robot teams, with a batched trajectory optimiser (thesis 5.2).

Spectral ergodic metric (Mathew and Mezic) on the unit square, uniform information over a region:
    F_k(x)   = cos(k_1 x_1) cos(k_2 x_2) / h_k,   k = pi * (i, j), i, j in {0 .. n-1}
    h_k      = sqrt(1/2) per non-zero index (so F_k has unit norm on [0, 1]^2)
    phi_k    = mean of F_k over the pixels of the region (the target: uniform over the region)
    c_k      = sum over the team's observations of w_o F_k(x_o) / sum of w_o (w_o = coverage weight of
               the observing robot's species, Table 5.3)
    E        = sum_k Lambda_k (c_k - phi_k)^2,   Lambda_k = (1 + |k|^2)^-1.5
A team without robots has no observation, so c_k = 0 for every k and E = sum_k Lambda_k phi_k^2
(>= Lambda_0 phi_0^2 = 1): the metric's own value, no constant is chosen for it.

Coverage cost (the objective everywhere; E is the raw metric). E's scale depends on the region (a
small region has large phi_k and small admissible errors), and a covered region costs ~1e-3 while an
empty one costs >= 1, so summing raw E over regions mostly counts empty regions. We measure each
team in the metric's own unit, the expected metric of one observation at a random point of its region:
    G_i = E_{x ~ U(region i)} [ sum_k Lambda_k (F_k(x) - phi_k)^2 ] = sum_k Lambda_k Var_{x~U(i)} F_k(x)
(the k = 0 term is 0: F_0 = 1). For N independent uniform observations c_k - phi_k is a mean of N
zero-mean terms of variance Var F_k, so E[E] = G_i / N exactly: e_i = E_i / G_i = 1/N means "as good
as N random glances at the region". The allocation's coverage cost is the area-weighted sum over its
K teams (the thesis sums the teams' costs; weighting by a_i, the region's share of the chip's pixels,
keeps the scale independent of K and of how the chip is cut):
    coverage cost = sum_i a_i E_i / G_i.
So covering every region as well as N random glances costs 1/N; a region left empty adds
a_i sum_k Lambda_k phi_k^2 / G_i (about 4 for K = 8 on our chips), which puts any allocation that
leaves a region empty outside the hypervolume box (reference 0.25 = 4 glances per region), while
one moving robot per region with 20 optimised observations lands well inside it (~0.05).

Trajectories: every robot takes `n_observations` observations x_0 .. x_{T-1}; x_0 is its deployment
point, drawn uniformly in its region on terrain it can move on. Step t moves the robot by
    d_t = L(x_t) * u_t / sqrt(1 + |u_t|^2)   (so |d_t| < L(x_t), the species' step length on the
                                               terrain under it, see species.SPEED_SCALE)
and then looks at `substeps` evenly spaced points along d_t: the step is cut short before the first
point on terrain where the species has speed 0, and scaled down by the slowest terrain it passes.
So a robot can never enter such terrain, and cannot jump across a band of it wider than
max step length / substeps (0.15 / 8 = 0.019 of the chip side, 6 pixels at 300 px, by default).
The controls u (one 2-vector per step) are optimised by Adam on the summed raw team metrics E, all
robots of all teams of all candidate allocations at once (the public code also uses gradient
descent; the thesis says MPC). Teams do not interact, so batching does not change any team's result.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass

import numpy as np
import torch

from robocompose.io.errors import check_field
from robocompose.teams.decompose import pixel_centres
from robocompose.teams.species import coverage_weights, step_lengths

# Where a coverage cost's code starts: a chip's targets, the deployment draws, the trajectory optimiser, the cost.
RESULT_CODE = ("robocompose.teams.ergodic:ChipCoverage",)


@dataclass(frozen=True)
class CoverageConfig:
    n_coefficients: int = 10  # Fourier indices per dimension: k = pi * {0 .. n-1}
    n_observations: int = 20  # observations (waypoints) per robot, x_0 being the deployment point
    substeps: int = 8  # points checked along every step for impassable / slower terrain
    iterations: int = 30  # Adam steps of the trajectory optimiser
    learning_rate: float = 0.15  # Adam step size on the controls u
    initial_control_std: float = 1.0  # controls start as N(0, std^2): robots start moving apart
    robots_per_species: int = 20  # N_j, robots of each species in the bank

    def __post_init__(self) -> None:
        for name in ("n_coefficients", "substeps", "robots_per_species"):
            check_field(getattr(self, name) >= 1, name, "an integer >= 1", getattr(self, name))
        check_field(self.n_observations >= 2, "n_observations", "an integer >= 2 (the start and a step)",
                    self.n_observations)
        check_field(self.iterations >= 0, "iterations", "an integer >= 0", self.iterations)
        check_field(self.learning_rate > 0, "learning_rate", "a number > 0", self.learning_rate)
        check_field(self.initial_control_std >= 0, "initial_control_std", "a number >= 0", self.initial_control_std)

    def settings_hash(self) -> str:
        """16 hex digits of every setting and of the code that shape a coverage cost (the cache key part)."""
        from robocompose.io.provenance import result_digest, settings_digest

        return settings_digest({"settings": asdict(self), "code": result_digest(*RESULT_CODE)})


def frequencies(n: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Return (h, Lambda), both (n, n) float64: basis normalisers and Sobolev weights."""
    index = torch.arange(n, dtype=torch.float64)
    h_1d = torch.where(index == 0, 1.0, 0.5**0.5)
    k_squared = (torch.pi * index) ** 2
    return h_1d[:, None] * h_1d[None, :], (1.0 + k_squared[:, None] + k_squared[None, :]) ** -1.5


def region_targets(regions: np.ndarray, n_regions: int, n: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Targets and glance costs of the uniform distribution over each region of an (H, W) raster.

    Returns (phi (K, n, n) float64, G (K,) float64): phi_k of each region and G, the expected metric
    of one observation drawn uniformly over the region's pixels (sum_k Lambda_k Var F_k).
    """
    height, width = regions.shape
    h, sobolev = frequencies(n)
    cos_x = torch.cos(torch.pi * torch.arange(n)[None, :] * (torch.arange(width)[:, None] + 0.5) / width)
    cos_y = torch.cos(torch.pi * torch.arange(n)[None, :] * (torch.arange(height)[:, None] + 0.5) / height)
    cos_x, cos_y = cos_x.double(), cos_y.double()
    one_hot = torch.nn.functional.one_hot(torch.as_tensor(regions), n_regions).double()  # (H, W, K)
    pixels = one_hot.sum((0, 1))[:, None, None]  # (K, 1, 1)
    phi = torch.einsum("hwk,hj,wi->kij", one_hot, cos_y, cos_x) / pixels / h  # i: x index, j: y
    second_moment = torch.einsum("hwk,hj,wi->kij", one_hot, cos_y**2, cos_x**2) / pixels / h**2
    return phi, (sobolev * (second_moment - phi**2)).sum((-2, -1))


def ergodic_cost(observations: torch.Tensor, weights: torch.Tensor, team: torch.Tensor, phi: torch.Tensor,
                 ) -> torch.Tensor:
    """Ergodic metric of every team: (n_teams,) costs.

    observations: (N, T, 2) robots' observations in the unit square; weights: (N, T) coverage weight of
    each observation; team: (N,) int64 team each robot belongs to; phi: (n_teams, n, n) team targets.
    """
    n = phi.shape[-1]
    phi = phi.to(observations.dtype)
    h, sobolev = (t.to(observations.dtype) for t in frequencies(n))
    k = torch.pi * torch.arange(n, dtype=observations.dtype)
    cos_x = torch.cos(observations[..., :1] * k)  # (N, T, n)
    cos_y = torch.cos(observations[..., 1:] * k)  # (N, T, n)
    per_robot = torch.bmm((cos_x * weights[..., None]).transpose(1, 2), cos_y)  # (N, n, n): sum_t w F h
    weighted_sum = torch.zeros_like(phi).index_add_(0, team, per_robot)  # (n_teams, n, n)
    total_weight = torch.zeros(len(phi), dtype=observations.dtype).index_add_(0, team, weights.sum(1))
    c = weighted_sum / h / total_weight.clamp_min(1e-12)[:, None, None]  # 0 for a team without robots
    return (sobolev * (c - phi) ** 2).sum((-2, -1))


@dataclass
class Robots:
    """A flat batch of robots from any number of teams (and candidate allocations)."""

    species: torch.Tensor  # (N,) int64 species id
    team: torch.Tensor  # (N,) int64 team index
    start: torch.Tensor  # (N, 2) deployment point
    controls: torch.Tensor  # (N, T-1, 2) initial controls


def rollout(robots: Robots, controls: torch.Tensor, terrain: torch.Tensor, substeps: int) -> torch.Tensor:
    """(N, T, 2) observations of robots driven by (N, T-1, 2) controls over an (H, W) terrain map."""
    height, width = terrain.shape
    lengths = torch.as_tensor(step_lengths(), dtype=controls.dtype)  # (O, M)
    length_map = lengths[:, terrain].reshape(-1)  # (O*H*W,) step length of species o at each pixel
    robot_offset = robots.species * (height * width)  # (N,)

    def step_length_at(points: torch.Tensor) -> torch.Tensor:  # (N, ..., 2) -> (N, ...)
        col = (points[..., 0] * width).long().clamp_(0, width - 1)
        row = (points[..., 1] * height).long().clamp_(0, height - 1)
        offset = robot_offset.view(-1, *[1] * (points.dim() - 2))
        return length_map[offset + row * width + col]

    fractions = torch.arange(1, substeps + 1, dtype=controls.dtype)[None, :, None] / substeps  # (1, S, 1)
    direction = controls / torch.sqrt(1 + (controls**2).sum(-1, keepdim=True))  # (N, T-1, 2), |.| < 1
    position, observations = robots.start, [robots.start]
    for t in range(controls.shape[1]):
        length_here = step_length_at(position)  # (N,)
        target = position + length_here[:, None] * direction[:, t]
        move = target.clamp(0.0, 1.0 - 1e-6) - position  # (N, 2)
        along = step_length_at(position[:, None] + fractions * move[:, None])  # (N, S)
        open_prefix = torch.cumprod((along > 0).to(controls.dtype), dim=1)  # 1 until the first blocked point
        reachable = open_prefix.sum(1) / substeps  # share of the step before impassable terrain
        slowest = torch.where(open_prefix > 0, along, torch.inf).amin(1)  # inf if the first point is blocked
        slowdown = torch.where(length_here > 0, slowest / length_here.clamp_min(1e-12), 0.0)
        position = position + torch.minimum(reachable, slowdown).clamp(max=1.0)[:, None] * move
        observations.append(position)
    return torch.stack(observations, dim=1)


def optimise_trajectories(robots: Robots, phi: torch.Tensor, terrain: torch.Tensor,
                          config: CoverageConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """Optimise every robot's controls for its team's ergodic cost.

    phi: (n_teams, n, n) team targets; terrain: (H, W) int64 terrain ids.
    Returns (raw team metrics E (n_teams,) float64 of the final trajectories, observations (N, T, 2)).
    """
    species_weight = torch.as_tensor(coverage_weights(), dtype=torch.float32)[robots.species]  # (N,)
    weights = species_weight[:, None].expand(-1, config.n_observations)  # (N, T)
    controls = robots.controls.clone().requires_grad_(True)
    optimiser = torch.optim.Adam([controls], lr=config.learning_rate)
    for _ in range(config.iterations):
        observations = rollout(robots, controls, terrain, config.substeps)  # (N, T, 2)
        loss = ergodic_cost(observations, weights, robots.team, phi).sum()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    with torch.no_grad():
        observations = rollout(robots, controls, terrain, config.substeps)
        costs = ergodic_cost(observations.double(), weights.double(), robots.team, phi)
    return costs, observations


def allocation_id(counts: np.ndarray) -> str:
    """Canonical id of a (K, O) integer allocation: sha1 of its shape and int16 counts."""
    counts = np.ascontiguousarray(counts, dtype=np.int16)
    return hashlib.sha1(repr(counts.shape).encode() + counts.tobytes()).hexdigest()[:16]


class ChipCoverage:
    """Coverage cost of allocations on one decomposed chip (terrain map + region raster)."""

    def __init__(self, terrain: np.ndarray, regions: np.ndarray, n_regions: int, config: CoverageConfig):
        self.config = config
        self.n_regions = n_regions
        self.regions = regions  # (H, W) region index of every pixel
        self.terrain = torch.as_tensor(terrain.astype(np.int64))  # (H, W)
        self.phi, self.glance = region_targets(regions, n_regions, config.n_coefficients)  # (K, n, n), (K,)
        self.area = torch.as_tensor(np.bincount(regions.ravel(), minlength=n_regions) / regions.size)  # (K,)
        height, width = terrain.shape
        self.centres = pixel_centres(height, width).reshape(-1, 2)  # (H*W, 2)
        self.pixel_size = np.array([1.0 / width, 1.0 / height])
        movable = step_lengths()[:, terrain.ravel()] > 0  # (O, H*W)
        self.deploy_pixels = [[self._deploy_pixels(regions.ravel() == i, can_move) for can_move in movable]
                              for i in range(n_regions)]  # [K][O] flat pixel indices

    @staticmethod
    def _deploy_pixels(in_region: np.ndarray, can_move: np.ndarray) -> np.ndarray:
        """Pixels of a region where a species can move, or all the region's pixels if there are none."""
        movable = np.flatnonzero(in_region & can_move)
        return movable if len(movable) else np.flatnonzero(in_region)

    def deploy(self, counts: np.ndarray, seed: int) -> Robots:
        """Robots of (B, K, O) allocations; allocation b's team in region i is team b * K + i.

        The team in region i with species counts n_i draws its robots' deployment points and initial
        controls from its own Generator((seed, i, *n_i)), so a team's plan and cost depend only on its
        region and its counts: an allocation's cost is a sum of team costs, and neither depends on the
        rest of the batch.
        """
        species, team, start, controls = [], [], [], []
        for b, allocation in enumerate(counts):
            for i in np.flatnonzero(allocation.sum(1)):
                rng = np.random.default_rng([seed, int(i), *(int(n) for n in allocation[i])])
                for j in np.flatnonzero(allocation[i]):
                    n = int(allocation[i, j])
                    pixels = self.deploy_pixels[i][j][rng.integers(len(self.deploy_pixels[i][j]), size=n)]
                    start.append(self.centres[pixels] + (rng.random((n, 2)) - 0.5) * self.pixel_size)
                    controls.append(rng.standard_normal((n, self.config.n_observations - 1, 2))
                                    * self.config.initial_control_std)
                    species.append(np.full(n, j))
                    team.append(np.full(n, b * self.n_regions + i))
        if not species:
            empty = torch.zeros(0, dtype=torch.int64)
            return Robots(empty, empty, torch.zeros(0, 2), torch.zeros(0, self.config.n_observations - 1, 2))
        return Robots(torch.as_tensor(np.concatenate(species)), torch.as_tensor(np.concatenate(team)),
                      torch.as_tensor(np.concatenate(start), dtype=torch.float32),
                      torch.as_tensor(np.concatenate(controls), dtype=torch.float32))

    def evaluate(self, counts: np.ndarray, seed: int) -> tuple[np.ndarray, Robots, torch.Tensor]:
        """Coverage cost of (B, K, O) integer allocations, optimised together.

        Returns (coverage costs (B,) float64, the robots, their observations (N, T, 2)).
        """
        costs, robots, observations = self.evaluate_teams(counts, seed)
        return costs.sum(1), robots, observations

    def evaluate_teams(self, counts: np.ndarray, seed: int) -> tuple[np.ndarray, Robots, torch.Tensor]:
        """As `evaluate`, with the (B, K) team costs a_i E_i / G_i (their row sums are the coverage costs)."""
        counts = np.asarray(counts)
        robots = self.deploy(counts, seed)
        phi = self.phi.repeat(len(counts), 1, 1)  # (B*K, n, n)
        metrics, observations = optimise_trajectories(robots, phi, self.terrain, self.config)
        return self.team_costs(metrics), robots, observations

    def team_costs(self, metrics: torch.Tensor) -> np.ndarray:
        """(B, K) team costs a_i E_i / G_i of (B*K,) raw team metrics (team b*K + i in region i)."""
        return (metrics.reshape(-1, self.n_regions) / self.glance * self.area).numpy()

    def empty_team_costs(self) -> np.ndarray:
        """(K,) the team cost of each region without robots: a_i sum_k Lambda_k phi_k^2 / G_i."""
        _, sobolev = frequencies(self.config.n_coefficients)
        return self.team_costs((sobolev * self.phi**2).sum((-2, -1)))[0]  # as an optimised team's, to the bit

    def coverage_cost(self, metrics: torch.Tensor) -> np.ndarray:
        """(B,) coverage costs sum_i a_i E_i / G_i of (B*K,) raw team metrics."""
        return self.team_costs(metrics).sum(1)
