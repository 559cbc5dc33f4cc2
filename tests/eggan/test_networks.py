"""Generator and discriminator: the thesis 5.1 / 5.2 structure, and rows that depend on their own task only."""

import pytest
import torch

from robocompose.eggan.networks import Discriminator, Generator, NetworkConfig, height_features


def test_height_map_tasks_go_through_two_convolutions_and_flat_tasks_do_not():
    config = NetworkConfig(latent=8, hidden=16)
    image = Generator((50, 20), (6, 4), config)
    convs = [m for m in image.task.modules() if isinstance(m, torch.nn.Conv2d)]
    assert [(c.in_channels, c.out_channels, c.kernel_size) for c in convs] == [(1, 32, (3, 3)), (32, 32, (3, 3))]
    assert image.encode(torch.zeros(2, 50, 20)).shape == (2, 8)  # FC to P
    flat = Generator((4, 4, 1), (4, 3), config)
    assert not any(isinstance(m, torch.nn.Conv2d) for m in flat.modules())
    assert flat(torch.zeros(5, 8), flat.encode(torch.zeros(5, 4, 4, 1))).shape == (5, 4, 3)


@pytest.mark.parametrize("norm", ["layer", "none", "batch"])
@pytest.mark.parametrize("network", [Generator, Discriminator])
def test_in_training_a_row_depends_on_its_own_task_only_unless_batch_norm(network, norm):
    """Batch norm shifts one task's rows by the others' (a batch holds several tasks): the default must not."""
    torch.manual_seed(0)
    net = network((50, 20), (6, 4), NetworkConfig(latent=8, hidden=16, norm=norm)).train()
    tasks = torch.rand(4, 50, 20)
    inputs = torch.randn(4, 8) if network is Generator else torch.rand(4, 6, 4)
    together = net(inputs, net.encode(tasks))  # one batch of four tasks
    others = torch.cat([tasks[:1], torch.zeros(3, 50, 20)])  # the same first row among other tasks
    independent = torch.allclose(together[0], net(inputs, net.encode(others))[0], atol=1e-6)
    assert independent == (norm != "batch")
    assert not torch.allclose(together[0], together[1])  # a row does depend on its own task and input


def test_the_task_reaches_both_outputs():
    torch.manual_seed(0)
    config = NetworkConfig(latent=8, hidden=16)
    g, d = Generator((50, 20), (6, 4), config), Discriminator((50, 20), (6, 4), config)
    z, design = torch.randn(1, 8), torch.rand(1, 6, 4)
    flat, rough = torch.zeros(1, 50, 20), torch.rand(1, 50, 20)
    assert (g(z, g.encode(flat)) - g(z, g.encode(rough))).abs().max() > 1e-3
    assert (d(design, d.encode(flat)) - d(design, d.encode(rough))).abs().max() > 1e-4


@pytest.mark.parametrize("network", [Generator, Discriminator])
def test_a_height_map_code_keeps_its_scale_however_large_the_encoder_grows(network):
    """The hidden layers normalise their rows, so nothing bounds the encoder's scale: unnormalised, a trained
    encoder grew to codes of ~800 (z ~ 1) and a design's one-hot moved D's first layer 1/67 as much as the
    task did. The code is normalised itself, so the task cannot drown out z or the design."""
    torch.manual_seed(0)
    net = network((50, 20), (6, 4), NetworkConfig(latent=8, hidden=16)).eval()
    tasks = torch.rand(3, 50, 20)
    inputs = torch.randn(3, 8) if network is Generator else torch.rand(3, 6, 4)
    with torch.no_grad():
        net.task.fc.weight.mul_(10.0)
        net.task.fc.bias.mul_(10.0)
        before = net(inputs, net.encode(tasks))
        net.task.fc.weight.mul_(100.0)
        net.task.fc.bias.mul_(100.0)
        code = net.encode(tasks)
    assert torch.allclose(code.pow(2).mean(dim=1), torch.ones(3), atol=1e-3)  # unit scale per row, like z
    assert torch.allclose(net(inputs, code), before, atol=1e-4)  # 100x the encoder's scale changes nothing


def test_bad_sizes():
    with pytest.raises(ValueError, match="network.hidden"):
        NetworkConfig(hidden=0)
    with pytest.raises(ValueError, match="network.norm"):
        NetworkConfig(norm="group")
    with pytest.raises(ValueError, match="at least 5 x 5"):
        Generator((4, 4), (6, 4), NetworkConfig())
    with pytest.raises(ValueError, match=r"^network\.encoder: expected one of \['conv', 'pooled', 'features'\], "
                       "found 'mlp'"):
        NetworkConfig(encoder="mlp")
    with pytest.raises(ValueError, match=r"^network\.segments: expected a positive integer, found 0"):
        NetworkConfig(segments=0)
    with pytest.raises(ValueError, match=r"^network\.segments: expected at most 46 stretches of a 50-cell course "
                       r"\(encoder pooled\), found 47"):
        Generator((50, 20), (6, 4), NetworkConfig(encoder="pooled", segments=47))


def test_the_small_encoders_read_the_course_in_stretches_with_few_weights():
    config = NetworkConfig(latent=8, hidden=16)
    sizes = {}
    for encoder in ("conv", "pooled", "features"):
        net = Generator((50, 20), (6, 4), NetworkConfig(latent=8, hidden=16, encoder=encoder))
        sizes[encoder] = sum(p.numel() for p in net.task.parameters())
        assert net.encode(torch.rand(3, 50, 20)).shape == (3, 8)
    assert sizes["conv"] > 15 * sizes["pooled"] > 15 * sizes["features"]  # 198k, 11k, 440 weights (P 32: 763k)
    assert config.encoder == "conv"  # the thesis's: the default of the dataclass (old generator files load)


def test_height_features_are_each_stretchs_mean_tallest_and_raised_share():
    maps = torch.zeros(1, 10, 5)
    maps[0, 0:2, 0] = 0.3  # two raised cells in the first stretch (of 2)
    maps[0, 7, 1:3] = 0.1  # two in the second
    features = height_features(maps, 2).view(-1)
    means, tallest, raised = features[:2], features[2:4], features[4:6]
    assert torch.allclose(means, torch.tensor([0.6 / 25, 0.2 / 25]))
    assert torch.allclose(tallest, torch.tensor([0.3, 0.1])) and torch.allclose(raised, torch.tensor([0.08, 0.08]))
    assert torch.allclose(features[6:], torch.tensor([0.8 / 50, 0.3, 4 / 50]))  # the whole map
    # a block moved across the course (same stretch) reads the same; moved along it, it does not
    across, along = maps.clone(), maps.clone()
    across[0, 0:2, 0], across[0, 0:2, 3] = 0.0, 0.3
    along[0, 0:2, 0], along[0, 5:7, 0] = 0.0, 0.3
    assert torch.allclose(height_features(across, 2), height_features(maps, 2))
    assert not torch.allclose(height_features(along, 2), height_features(maps, 2))
    net = Generator((10, 5), (6, 4), NetworkConfig(latent=8, hidden=16, encoder="features", segments=2))
    assert torch.allclose(net.encode(across), net.encode(maps), atol=1e-5)
    assert not torch.allclose(net.encode(along), net.encode(maps), atol=1e-3)
