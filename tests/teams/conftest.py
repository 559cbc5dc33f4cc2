import pytest
import torch


@pytest.fixture(autouse=True)
def one_torch_thread():
    """The teams tensors are small: one thread is fastest and keeps results independent of the machine."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
