"""The long RL grid of issue 46: where the paper claims a baseline learns, run it until it does
(≥ 90 % episode success) or for up to 1 000 000 iterations, evaluated on a log-spaced schedule.

Every entry is a run of the store (`hadim resume` continues it like any baseline run). The grid
is driven stage by stage — every entry to 50 000 iterations, then to 200 000, then to its cap —
so an interrupted grid has a comparable picture of every entry rather than one finished run.
`run_grid` is idempotent: it skips entries that are done (learned, or at the stage's
iterations), continues the others from their last checkpoint, and creates the missing ones.
The entries are claimed as one sweep per variant in the store (`grid_sweep`), so that
`hadim report` draws them.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from hadim_cli.baselines import runs as baseline_runs
from hadim_cli.baselines.agents import Algorithm, make_config
from hadim_cli.baselines.variants import Variant, apply_variant
from hadim_cli.config import WorldConfig
from hadim_cli.evaluation.metric import EPISODE_ACTIONS, measure_name, zone_share

LOG_SCHEDULE = (1000, 2000, 5000, 10_000, 15_000, 20_000, 30_000, 50_000, 100_000, 200_000,
                500_000, 1_000_000)
"""Iterations evaluated at (both measures): log-spaced, denser where the paper's claims lie
(10 000–32 000)."""
STAGES = (50_000, 200_000, 1_000_000)
LEARNED = 0.9
"""Episode success (share of the task's points in the goal zone) at which a run has learned."""
CAP = 1_000_000
CURIOUS_CAP = 500_000
CHUNK = 5000
"""Iterations between checkpoints: an interrupted grid loses at most this much of a run."""
PAPER_HORIZON = 50_000
"""Iterations the exploration schedule spans: the paper's runs were 50 000 iterations, so ε
decays 1 → 0.05 over the first 5000 (SB3's fraction 0.1), as in the 50 000-iteration grids."""
SWEEP_FORMAT = 1
TASK_SHORT = {"move-robot": "move", "push-object": "push", "push-with-tool": "tool"}


@dataclass(frozen=True)
class GridEntry:
    """One run of the grid."""

    task: str
    algorithm: str
    reward: str
    seed: int
    variant: Variant = Variant.PAPER
    n_envs: int = 1

    @property
    def run(self) -> str:
        return (f"g-{TASK_SHORT[self.task]}-{self.algorithm}-{self.reward}-"
                f"{self.variant.value}-s{self.seed}")

    @property
    def label(self) -> str:
        """The report's group: algorithm (reward[, variant])."""
        extra = "" if self.variant is Variant.PAPER else f", {self.variant.value}"
        return f"{self.algorithm} ({self.reward}{extra})"

    @property
    def cap(self) -> int:
        return CURIOUS_CAP if self.algorithm == Algorithm.CURIOUS.value else CAP


def claimed_entries(variants: Iterable[Variant] = (Variant.PAPER,),
                    seeds: Iterable[int] = (0, 1, 2)) -> list[GridEntry]:
    """The grid, cheapest first within each task (measured iterations per CPU-second:
    q-learning ≈ 2200, a2c with 8 environments ≈ 1300, dqn and curious ≈ 450): the tasks and
    algorithms where the paper claims a success."""
    claims = [("move-robot", a, r) for a in ("q-learning", "a2c", "curious", "dqn")
              for r in ("sparse", "guided") if not (a == "curious" and r == "guided")]
    claims += [("push-object", a, "guided") for a in ("a2c", "dqn")]
    claims += [("push-with-tool", "curious", "sparse")]
    seeds = tuple(seeds)
    return [GridEntry(task, algo, reward, seed, variant, 8 if algo == "a2c" else 1)
            for variant in variants for task, algo, reward in claims for seed in seeds]


def grid_sweep(variant: Variant) -> str:
    """The sweep name a variant's entries are claimed under (`hadim report NAME`)."""
    return f"rl-grid-{variant.value}"


def config_of(entry: GridEntry, world: WorldConfig | None = None):
    cfg = make_config(entry.algorithm, entry.task, entry.reward, "discrete", PAPER_HORIZON, 0,
                      world or WorldConfig(), EPISODE_ACTIONS, CHUNK, entry.n_envs)
    cfg = dataclasses.replace(cfg, eval_at=tuple(i for i in LOG_SCHEDULE if i <= entry.cap))
    return apply_variant(cfg, entry.variant)


def claim(store, entries: list[GridEntry]) -> None:
    """Record each variant's entries as a sweep (a new entry list needs a new variant name)."""
    for variant in dict.fromkeys(e.variant for e in entries):
        mine = [e for e in entries if e.variant is variant]
        store.claim_sweep(grid_sweep(variant), {
            "format": SWEEP_FORMAT, "kind": "rl-grid",
            "entries": [{"run": e.run, "label": e.label, "task": e.task, "seed": e.seed,
                         "iterations": e.cap} for e in mine]})


def learned_at(store, entry: GridEntry) -> int | None:
    """The first iteration whose episode success reached `LEARNED` (None if none yet)."""
    name = measure_name(entry.task, EPISODE_ACTIONS)
    for e in store.evaluations(entry.run, task=name):
        if zone_share(e.points) >= LEARNED:
            return e.iteration
    return None


def _exists(store, name: str) -> bool:
    return any(r.name == name for r in store.list_runs())


def run_entry(store, entry: GridEntry, target: int, should_stop: Callable[[], bool],
              log: Callable[[str], None]) -> str:
    """Bring one entry to `target` iterations (or until it learns); what happened."""
    from hadim_cli import runs
    from hadim_cli.heartbeat import keep_alive
    from store.records import RunStatus

    if _exists(store, entry.run):
        record = store.get_run(entry.run)
        if learned_at(store, entry) is not None:
            return f"learned at {learned_at(store, entry)}"
        if record.iterations >= target:
            return f"at {record.iterations}"
    else:
        record = baseline_runs.new_run(store, config_of(entry), entry.seed, entry.run)
    began = time.monotonic()
    session = baseline_runs.restore(store, record)
    start = session.iteration
    owner = runs.owner_id()
    store.acquire_lock(entry.run, owner)
    store.set_status(entry.run, RunStatus.RUNNING)
    status = RunStatus.FAILED
    try:
        with keep_alive(store, entry.run, owner):
            baseline_runs.train(
                store, entry.run, session, target, eval_every=0, tasks=(entry.task,),
                should_stop=lambda: should_stop() or learned_at(store, entry) is not None,
                owner=owner)
        done = session.iteration >= entry.cap or learned_at(store, entry) is not None
        status = RunStatus.FINISHED if done else RunStatus.PAUSED
    finally:
        store.set_status(entry.run, status)
        store.release_lock(entry.run, owner)
    rate = (session.iteration - start) / max(time.monotonic() - began, 1e-9)
    log(f"{entry.run}: {start} → {session.iteration} ({rate:.0f} it/s wall, with "
        f"evaluations; {status.value})")
    return "stopped" if should_stop() else status.value


def run_grid(store, entries: list[GridEntry], should_stop: Callable[[], bool],
             log: Callable[[str], None], stages: Iterable[int] = STAGES) -> None:
    """Every entry to each stage's iterations in turn (capped), skipping what is done."""
    import torch

    torch.set_num_threads(1)
    claim(store, entries)
    for stage in stages:
        log(f"stage {stage}")
        for entry in entries:
            if should_stop():
                log("stopping: every run is at its last checkpoint")
                return
            outcome = run_entry(store, entry, min(stage, entry.cap), should_stop, log)
            log(f"{entry.run}: {outcome}")
    log("grid done")

