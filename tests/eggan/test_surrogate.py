"""The surrogate fitness model learns a task-dependent function, deterministically, and round-trips its state."""

import numpy as np
import torch

from robocompose.eggan.surrogate import Surrogate, SurrogateConfig, spearman


def _data(n, seed):
    rng = np.random.default_rng(seed)
    tasks = torch.rand(4, 10, 10)  # 4 distinct "height maps"
    index = torch.as_tensor(rng.integers(4, size=n))
    picks = rng.integers(4, size=(n, 6))
    designs = torch.nn.functional.one_hot(torch.as_tensor(picks), 4).float()
    values = (picks == 2).sum(1) + 3 * tasks.mean(dim=(1, 2)).numpy()[index.numpy()]  # wheels count, plus the task
    return tasks, index, designs, values


def test_fits_held_out_data_and_is_deterministic():
    tasks, index, designs, values = _data(400, 0)
    config = SurrogateConfig(steps=300, hidden=64)
    a, b = Surrogate((10, 10), (6, 4), config, seed=3), Surrogate((10, 10), (6, 4), config, seed=3)
    a.fit(tasks, index[:300], designs[:300], values[:300])
    b.fit(tasks, index[:300], designs[:300], values[:300])
    predicted = a.predict(tasks, index[300:], designs[300:])
    assert spearman(predicted, values[300:]) > 0.8
    assert np.array_equal(predicted, b.predict(tasks, index[300:], designs[300:]))
    c = Surrogate((10, 10), (6, 4), config)
    c.load_state_dict(a.state_dict())
    assert np.array_equal(c.predict(tasks, index[300:], designs[300:]), predicted)
