"""Generator and discriminator shapes (thesis 5.1 / 5.2 structure)."""

import pytest
import torch

from robocompose.eggan.networks import Discriminator, Generator, NetworkConfig


def test_height_map_tasks_go_through_two_convolutions_and_flat_tasks_do_not():
    config = NetworkConfig(latent=8, hidden=16)
    image = Generator((50, 20), (6, 4), config)
    convs = [m for m in image.task.modules() if isinstance(m, torch.nn.Conv2d)]
    assert [(c.in_channels, c.out_channels, c.kernel_size) for c in convs] == [(1, 32, (3, 3)), (32, 32, (3, 3))]
    assert image.encode(torch.zeros(2, 50, 20)).shape == (2, 8)  # FC to P
    flat = Generator((4, 4, 1), (4, 3), config)
    assert not any(isinstance(m, torch.nn.Conv2d) for m in flat.modules())
    assert flat(torch.zeros(5, 8), flat.encode(torch.zeros(5, 4, 4, 1))).shape == (5, 4, 3)
    norms = [m for m in image.body if isinstance(m, torch.nn.BatchNorm1d)]
    assert len(norms) == 3 and all(n.num_features == 16 for n in norms)


def test_discriminator_gives_one_logit_per_design():
    d = Discriminator((50, 20), (6, 4), NetworkConfig(latent=8, hidden=16))
    assert d(torch.zeros(3, 6, 4), d.encode(torch.zeros(3, 50, 20))).shape == (3,)


def test_bad_sizes():
    with pytest.raises(ValueError, match="network.hidden"):
        NetworkConfig(hidden=0)
    with pytest.raises(ValueError, match="at least 5 x 5"):
        Generator((4, 4), (6, 4), NetworkConfig())
