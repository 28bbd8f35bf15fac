"""Sequences of primitive actions: read from a file, or drawn at random."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hadim_cli.errors import ActionError, HadimError


def random_actions(rng: np.random.Generator, n: int) -> np.ndarray:
    """`n` primitive actions uniform in [-1, 1]², shape (n, 2)."""
    return rng.uniform(-1.0, 1.0, size=(n, 2))


def load_actions(path: Path) -> np.ndarray:
    """An (N, 2) array of actions from a `.npy` file or a text/CSV file of two columns."""
    path = Path(path)
    if not path.is_file():
        raise HadimError(f"actions file not found: {path}")
    try:
        if path.suffix == ".npy":
            actions = np.load(path, allow_pickle=False)
        else:
            text = path.read_text().replace(",", " ")
            actions = np.loadtxt(text.splitlines(), dtype=np.float64, ndmin=2)
    except (ValueError, OSError) as exc:
        raise HadimError(f"cannot read actions from {path}: {exc}") from None
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim != 2 or actions.shape[1] != 2:
        raise HadimError(f"actions file {path} must hold N rows of 2 intensities (left, right), "
                         f"got shape {actions.shape}")
    bad = ~(np.isfinite(actions).all(axis=1) & (np.abs(actions) <= 1.0).all(axis=1))
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ActionError(f"actions file {path}, row {row + 1}: {actions[row].tolist()} is not "
                          "in [-1, 1]²")
    return actions
