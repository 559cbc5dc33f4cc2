import numpy as np

from robocompose.teams.genomes import GENOMES
from robocompose.teams.nsga2 import deployment_share_draws
from robocompose.teams.species import allocation_to_counts, deployment_cost


def test_the_share_split_genome_moves_robots_or_changes_how_many_never_both():
    genome = GENOMES["share_split"]
    rng = np.random.default_rng(3)
    genes = rng.random((50, genome.size(4, 3)))  # (B, K*O + O): split weights, then shares
    fractions = genome.decode(genes, 4, 3)  # (B, K, O)
    np.testing.assert_allclose(fractions.sum(1), genes[:, -3:])  # each species deploys its share
    moved, grown = genes.copy(), genes.copy()
    moved[:, 5] = rng.random(50)  # a split weight (region 1, species 2) redrawn, as uniform mutation does
    grown[:, -1] = rng.random(50)  # species 2's share redrawn
    np.testing.assert_allclose(genome.decode(moved, 4, 3).sum(1), fractions.sum(1))
    assert not np.allclose(genome.decode(moved, 4, 3), fractions)
    np.testing.assert_allclose(genome.decode(grown, 4, 3)[..., :2], fractions[..., :2])
    np.testing.assert_allclose(genome.decode(genome.encode(fractions), 4, 3), fractions)
    # the thesis's genome: redrawing a gene of the first population (a typical 0.06) adds robots (the drift)
    raw = GENOMES["fractions"]
    first = raw.encode(deployment_share_draws(rng, 2000, 4, 3))  # (B, K*O)
    mutated = first.copy()
    mutated[:, 0] = rng.random(2000)
    robots = [deployment_cost(allocation_to_counts(raw.decode(g, 4, 3), 20)).mean() for g in (first, mutated)]
    assert robots[1] > robots[0] + 3
    zero = np.zeros((1, genome.size(4, 3)))
    zero[0, -3:] = 0.5
    np.testing.assert_allclose(genome.decode(zero, 4, 3), np.full((1, 4, 3), 0.125))  # all-zero split: even
