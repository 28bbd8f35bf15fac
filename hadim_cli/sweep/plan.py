"""A sweep's grid as typed entries: pure parsing and naming, no Ray, no store.

A sweep is identified by its name and its settings (every entry's kind, run name, resolved
config, seed, iterations and evaluation period). Re-running a sweep with the same settings
resumes it; other settings under the same name are refused.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from hadim_cli.config import Config, load_config
from hadim_cli.errors import HadimError

SWEEP_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,31}")
RUN_NAME_MAX = 64
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
SETTINGS_FORMAT = 1


class RunKind(StrEnum):
    """What a sweep entry runs. The RL baselines (issue 12) will add their kind here and a
    runner for it in `worker.RUNNERS`."""

    TRAIN = "train"


@dataclass(frozen=True)
class SweepEntry:
    """One run of a sweep."""

    run: str
    kind: RunKind
    label: str
    """The config's label: its file's stem (or `default`) and the grid's values."""
    seed: int
    config: dict[str, Any]
    iterations: int
    eval_every: int

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.run, "kind": self.kind.value, "label": self.label,
                "seed": self.seed, "config": self.config, "iterations": self.iterations,
                "eval_every": self.eval_every}


@dataclass(frozen=True)
class SweepPlan:
    name: str
    entries: tuple[SweepEntry, ...]

    def settings(self) -> dict[str, Any]:
        """What makes this sweep this sweep (stored with its name; compared on a re-run)."""
        return {"format": SETTINGS_FORMAT, "entries": [e.to_dict() for e in self.entries]}


def parse_seeds(text: str) -> list[int]:
    """`0-9`, `0,3,7`, `0-4,10`: distinct non-negative seeds, in the order given."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        match = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
        if not match:
            raise HadimError(f"--seeds {text!r}: use a list and ranges like 0-9 or 0,3,7")
        low = int(match.group(1))
        high = int(match.group(2) or low)
        if high < low:
            raise HadimError(f"--seeds {text!r}: range {part} runs backwards")
        seeds += [s for s in range(low, high + 1) if s not in seeds]
    return seeds


def parse_grid(items: Iterable[str]) -> list[tuple[str, list[str]]]:
    """`learner.sigma=0,0.5,1` → (key, values); the values are checked later as overrides."""
    grid: list[tuple[str, list[str]]] = []
    for item in items:
        key, sep, raw = item.partition("=")
        key = key.strip()
        values = [v.strip() for v in raw.split(",")]
        if not sep or not re.fullmatch(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)+", key) or not all(values):
            raise HadimError(f"--grid {item!r}: use section.key=value1,value2,...")
        if any(key == k for k, _ in grid):
            raise HadimError(f"--grid {key} is given twice")
        grid.append((key, values))
    return grid


def _label(stem: str, combo: Sequence[tuple[str, str]]) -> str:
    parts = [stem] + [f"{key.rsplit('.', 1)[-1]}{value}" for key, value in combo]
    return _UNSAFE.sub("~", "_".join(parts)).replace("~", "")


def build_plan(name: str, *, configs: Sequence[Path], grid: Sequence[str], sets: Sequence[str],
               seeds: str, iterations: int, eval_every: int | None) -> SweepPlan:
    """Every (config, grid combination, seed) as an entry; configs validated up front."""
    if not SWEEP_NAME_RE.fullmatch(name):
        raise HadimError(f"invalid sweep name {name!r}: use 1-32 letters, digits, '.', '_' "
                         "or '-', starting with a letter or digit")
    seed_list = parse_seeds(seeds)
    axes = parse_grid(grid)
    combos = list(itertools.product(*[[(k, v) for v in vs] for k, vs in axes]))
    entries: list[SweepEntry] = []
    for path in configs or [None]:
        stem = "default" if path is None else Path(path).stem
        for combo in combos:
            overrides = list(sets) + [f"{k}={v}" for k, v in combo]
            config = load_config(path, overrides)
            every = _eval_every(eval_every, config)
            label = _label(stem, combo)
            for seed in seed_list:
                run = f"{name}-{label}-s{seed}"
                if len(run) > RUN_NAME_MAX:
                    raise HadimError(f"run name {run!r} is longer than {RUN_NAME_MAX} "
                                     "characters: use a shorter sweep name or config file name")
                entries.append(SweepEntry(run, RunKind.TRAIN, label, seed, config.to_dict(),
                                          iterations, every))
    names = [e.run for e in entries]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise HadimError(f"two entries of the sweep would be named {clash[0]}: give the config "
                         "files different names")
    return SweepPlan(name, tuple(entries))


def _eval_every(option: int | None, config: Config) -> int:
    every = config.evaluation.every if option is None else option
    if every and every % config.world.episode_length:
        raise HadimError(f"--eval-every must be a multiple of the episode length "
                         f"({config.world.episode_length}), got {every}")
    return every
