"""Fixtures shared by the learner's tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def one_thread():
    """As a `Session` does: on 2 shared cores, torch's thread pool only waits (modules that
    train p_A many times ask for it with `pytestmark = pytest.mark.usefixtures(...)`)."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
