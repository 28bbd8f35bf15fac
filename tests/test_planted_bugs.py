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


def test_every_planted_bug_still_names_one_line_of_its_file_and_stays_python():
    """Fast and always run: each bug's text occurs exactly once in its file (an edit of the
    code that moves it leaves the bug unplantable, and the slow run above stops at it — one
    did, unnoticed, for a session), and the file with the bug planted still compiles (a bug
    that does not even import proves nothing)."""
    problems = {bug.name: why for bug in plant_bugs.BUGS
                if (why := plant_bugs.unplantable(bug)) is not None}
    assert not problems, problems
    assert len({b.name for b in plant_bugs.BUGS}) == len(plant_bugs.BUGS)
