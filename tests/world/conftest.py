"""Fixtures of the world's tests (the helpers are in worldmade.py)."""

from __future__ import annotations

import pytest

from hadim_cli.config import WorldConfig
from hadim_cli.world.world import World


@pytest.fixture
def default_world() -> World:
    return World(WorldConfig())
