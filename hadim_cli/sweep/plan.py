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
    """What a sweep entry runs; each kind has its runner in `worker.RUNNERS`."""

    TRAIN = "train"
    """A learning session of the learner (`hadim train`)."""
    BASELINE = "baseline"
    """A reinforcement-learning baseline (`hadim baseline train`)."""


@dataclass(frozen=True)
class BaselineGrid:
    """The RL comparison's axes (`hadim sweep --algo …`): one run per algorithm × task ×
    reward × actions × seed that the algorithm takes (curious: sparse only; continuous
    actions: a2c only); the others are left out and listed."""

    algorithms: tuple[str, ...]
    tasks: tuple[str, ...]
    rewards: tuple[str, ...]
    actions: tuple[str, ...] = ("discrete",)


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
    left_out: tuple[str, ...] = ()
    """Combinations of a baseline grid that no algorithm of it takes (not part of the sweep)."""

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
               seeds: str, iterations: int, eval_every: int | None,
               baselines: BaselineGrid | None = None) -> SweepPlan:
    """Every (config, grid combination, seed) as an entry, then every baseline of
    `baselines`; configs validated up front. With `baselines` and no config file, the sweep
    holds the baselines only."""
    if not SWEEP_NAME_RE.fullmatch(name):
        raise HadimError(f"invalid sweep name {name!r}: use 1-32 letters, digits, '.', '_' "
                         "or '-', starting with a letter or digit")
    seed_list = parse_seeds(seeds)
    entries: list[SweepEntry] = []
    left_out: tuple[str, ...] = ()
    if baselines is not None and not configs and (grid or sets):
        raise HadimError("--grid and --set change the learner's config: with --algo, give "
                         "the learner's config files with -c too, or leave them out")
    if baselines is None or configs:
        entries += _learner_entries(name, configs, grid, sets, seed_list, iterations,
                                    eval_every)
    if baselines is not None:
        more, left_out = _baseline_entries(name, baselines, seed_list, iterations, eval_every)
        entries += more
    names = [e.run for e in entries]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise HadimError(f"two entries of the sweep would be named {clash[0]}: give the config "
                         "files different names")
    return SweepPlan(name, tuple(entries), left_out)


def _run_name(name: str, label: str, seed: int) -> str:
    run = f"{name}-{label}-s{seed}"
    if len(run) > RUN_NAME_MAX:
        raise HadimError(f"run name {run!r} is longer than {RUN_NAME_MAX} characters: use a "
                         "shorter sweep name or config file name")
    return run


def _learner_entries(name: str, configs: Sequence[Path], grid: Sequence[str],
                     sets: Sequence[str], seed_list: list[int], iterations: int,
                     eval_every: int | None) -> list[SweepEntry]:
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
                entries.append(SweepEntry(_run_name(name, label, seed), RunKind.TRAIN, label,
                                          seed, config.to_dict(), iterations, every))
    return entries


BASELINE_EVAL_EVERY = 1000
"""A baseline's evaluation period when --eval-every is not given (the paper's Fig. 5 grid)."""


def _baseline_entries(name: str, axes: BaselineGrid, seed_list: list[int], iterations: int,
                      eval_every: int | None) -> tuple[list[SweepEntry], tuple[str, ...]]:
    """One entry per combination an algorithm takes and seed; the others, named."""
    from hadim_cli.baselines.config import (
        Actions,
        Algorithm,
        check_total,
        choice,
        make_config,
        refusal,
    )
    from hadim_cli.baselines.rewards import Reward
    from hadim_cli.baselines.tasks import TASKS
    from hadim_cli.config import WorldConfig

    check_total(iterations)
    for task in axes.tasks:
        if task not in TASKS:
            raise HadimError(f"unknown task '{task}' (known: {', '.join(TASKS)})")
    every = BASELINE_EVAL_EVERY if eval_every is None else eval_every
    entries: list[SweepEntry] = []
    left_out: list[str] = []
    for algo, task, reward, actions in itertools.product(
            axes.algorithms, axes.tasks, axes.rewards, axes.actions):
        why = refusal(choice(Algorithm, algo, "algorithm"), choice(Reward, reward, "reward"),
                      choice(Actions, actions, "actions"))
        label = "-".join([algo, reward, task] + (["continuous"] if actions != "discrete"
                                                 else []))
        if why is not None:
            left_out.append(f"{label}: {why.split(':')[0]}")
            continue
        config = make_config(algo, task, reward, actions, iterations, every, WorldConfig())
        for seed in seed_list:
            entries.append(SweepEntry(_run_name(name, label, seed), RunKind.BASELINE, label,
                                      seed, config.to_dict(), iterations, every))
    if not entries:
        raise HadimError("no algorithm of --algo takes these rewards and actions: "
                         + "; ".join(left_out))
    return entries, tuple(left_out)


def parse_list(text: str, what: str) -> tuple[str, ...]:
    """`dqn,a2c` → ("dqn", "a2c"), distinct, in the order given."""
    values = tuple(dict.fromkeys(v.strip() for v in text.split(",")))
    if not all(values):
        raise HadimError(f"--{what} {text!r}: use a comma-separated list")
    return values


def _eval_every(option: int | None, config: Config) -> int:
    every = config.evaluation.every if option is None else option
    if every and every % config.world.episode_length:
        raise HadimError(f"--eval-every must be a multiple of the episode length "
                         f"({config.world.episode_length}), got {every}")
    return every
