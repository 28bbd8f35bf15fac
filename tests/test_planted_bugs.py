"""Every one-line bug of scripts/plant_bugs.py is caught by the tests named for it.

Slow (about 10 minutes: one pytest run per bug) and it rewrites source files of this checkout
while it runs (each restored in a `finally`), so it is opt-in: `pytest -m slow`.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location(
    "plant_bugs", Path(__file__).resolve().parents[1] / "scripts" / "plant_bugs.py")
assert _SPEC is not None and _SPEC.loader is not None
plant_bugs = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(plant_bugs)


@pytest.mark.slow
@pytest.mark.parametrize("bug", plant_bugs.BUGS, ids=[b.name for b in plant_bugs.BUGS])
def test_a_planted_bug_is_caught(bug):
    assert plant_bugs.plant(bug) == "caught"
