import pytest


@pytest.fixture(autouse=True)
def teams_tensors_on_one_thread(one_torch_thread):
    """The teams tensors are small: one thread is fastest and keeps results independent of the machine."""
