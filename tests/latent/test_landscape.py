import numpy as np
import torch

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.latent.constraints import replay
from robocompose.latent.landscape import LandscapeConfig, landscape, principal_components
from robocompose.latent.model import GraphVAE, VAEConfig
from robocompose.latent.train import Designs


def test_principal_components_find_the_long_axis():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 3)) * [5.0, 1.0, 0.1] @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    xy, explained = principal_components(x)
    assert explained[0] > 0.9 > explained[1] > 0.03
    assert np.var(xy[:, 0]) > 20 * np.var(xy[:, 1]) / 2
    np.testing.assert_allclose(principal_components(x[::-1])[0], xy[::-1], atol=1e-9)  # sign fixed by the loadings


def test_landscape_scores_the_subset_with_the_evaluator(make_trees):
    torch.manual_seed(0)
    trees = make_trees(10, 0, min_links=11)  # dataset-like designs (all have hinges)
    designs = Designs([t.design_id for t in trees], trees, [replay(t, "grammar", 50) for t in trees],
                      np.zeros((len(trees), 16), dtype=np.float32))
    models = {name: GraphVAE(VAEConfig(hidden=8, latent=3)) for name in ("full", "nopred")}
    quick = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=2))
    table = landscape(models, designs, LandscapeConfig(designs=10, evaluated=2), quick)
    assert len(table) == 20 and set(table["variant"]) == {"full", "nopred"}
    for _, part in table.groupby("variant"):
        assert (part["status"] != "").sum() == 2 and part["status"].iloc[2:].eq("").all()
        assert abs(part["pc1"].mean()) < 1e-6  # centred
    full, nopred = (table[table["variant"] == v].reset_index() for v in ("full", "nopred"))
    assert list(full["design_id"]) == list(nopred["design_id"])
    assert full["reward"].iloc[:2].equals(nopred["reward"].iloc[:2])  # same designs, same scores
