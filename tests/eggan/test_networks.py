"""Generator and discriminator: the thesis 5.1 / 5.2 structure, and rows that depend on their own task only."""

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
