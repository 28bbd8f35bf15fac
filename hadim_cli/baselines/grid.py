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
from contextlib import contextmanager
from dataclasses import dataclass

from hadim_cli.baselines import runs as baseline_runs
from hadim_cli.baselines.config import Algorithm, make_config
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


def grid_sweep(variant: str) -> str:
    """The sweep name a variant's entries are claimed under (`hadim report NAME`):
    rl-grid-paper, rl-grid-fixed, rl-grid-learner."""
    return f"rl-grid-{variant}"


def config_of(entry: GridEntry, world: WorldConfig | None = None):
    cfg = make_config(entry.algorithm, entry.task, entry.reward, "discrete", PAPER_HORIZON, 0,
                      world or WorldConfig(), EPISODE_ACTIONS, CHUNK, entry.n_envs)
    cfg = dataclasses.replace(cfg, eval_at=tuple(i for i in LOG_SCHEDULE if i <= entry.cap))
    return apply_variant(cfg, entry.variant)


def claim(store, entries: list) -> None:
    """Record each variant's entries (and the learner's) as a sweep, `grid_sweep(variant)`."""
    for variant in dict.fromkeys(e.variant for e in entries):
        mine = [e for e in entries if e.variant == variant]
        store.claim_sweep(grid_sweep(variant), {
            "format": SWEEP_FORMAT, "kind": "rl-grid",
            "entries": [{"run": e.run, "label": e.label, "task": getattr(e, "task", "all"),
                         "seed": e.seed, "iterations": e.cap} for e in mine]})


def learned_at(store, entry: GridEntry) -> int | None:
    """The first iteration whose episode success reached `LEARNED` (None if none yet)."""
    name = measure_name(entry.task, EPISODE_ACTIONS)
    for e in store.evaluations(entry.run, task=name):
        if zone_share(e.points) >= LEARNED:
            return e.iteration
    return None


def _exists(store, name: str) -> bool:
    return any(r.name == name for r in store.list_runs())


@contextmanager
def _locked(store, run: str):
    """The run's lock and heartbeat; its status `running` while held, then what the body
    sets in the yielded dict (`failed` if it raised)."""
    from hadim_cli import runs
    from hadim_cli.heartbeat import keep_alive
    from hadim_store.records import RunStatus

    owner = runs.owner_id()
    store.acquire_lock(run, owner)
    store.set_status(run, RunStatus.RUNNING)
    outcome = {"owner": owner, "status": RunStatus.FAILED}
    try:
        with keep_alive(store, run, owner):
            yield outcome
    finally:
        store.set_status(run, outcome["status"])
        store.release_lock(run, owner)


def run_entry(store, entry: GridEntry, target: int, should_stop: Callable[[], bool],
              log: Callable[[str], None]) -> str:
    """Bring one baseline entry to `target` iterations (or until it learns)."""
    from hadim_store.records import RunStatus

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
    with _locked(store, entry.run) as outcome:
        baseline_runs.train(
            store, entry.run, session, target, eval_every=0, tasks=(entry.task,),
            should_stop=lambda: should_stop() or learned_at(store, entry) is not None,
            owner=outcome["owner"])
        done = session.iteration >= entry.cap or learned_at(store, entry) is not None
        outcome["status"] = RunStatus.FINISHED if done else RunStatus.PAUSED
    rate = (session.iteration - start) / max(time.monotonic() - began, 1e-9)
    return (f"{start} → {session.iteration} ({rate:.0f} it/s wall with evaluations; "
            f"{outcome['status'].value})")


@dataclass(frozen=True)
class LearnerEntry:
    """The learner (default config) on the same axes: trained to `iterations`, evaluated on
    every task with both measures at `LEARNER_SCHEDULE`."""

    seed: int
    iterations: int = 4000

    @property
    def run(self) -> str:
        return f"g-learner-default-s{self.seed}"

    label = "hadim (default)"
    variant = "learner"

    @property
    def cap(self) -> int:
        return self.iterations


LEARNER_SCHEDULE = (100, 200, 500, 1000, 2000, 4000)
TASKS = ("move-robot", "push-object", "push-with-tool")


def learner_measures(session, store, run: str) -> None:
    """Both measures of every task at the session's iteration (the episode one as
    `TASK@1000`), unless already stored (a grid killed between training and evaluating)."""
    from hadim_cli.evaluation.runner import evaluate
    from hadim_cli.evaluation.tasks import load_task

    it = session.iteration
    done = {e.task for e in store.evaluations(run) if e.iteration == it}
    for name in TASKS:
        task = load_task(name)
        for chosen in (task, dataclasses.replace(task, budget=EPISODE_ACTIONS,
                                                 name=measure_name(name, EPISODE_ACTIONS))):
            if chosen.name in done:
                continue
            result = evaluate(session.learner, session.config.world, chosen)
            store.add_evaluation(run, it, chosen.name, result.score, result.to_dict()["points"])


def run_learner(store, entry: LearnerEntry, target: int, should_stop: Callable[[], bool],
                log: Callable[[str], None]) -> str:  # noqa: ARG001
    from hadim_cli import runs
    from hadim_cli.config import load_config
    from hadim_store.records import RunStatus

    if not _exists(store, entry.run):
        runs.new_run(store, load_config(), entry.seed, entry.run)
    record = store.get_run(entry.run)
    points = [i for i in LEARNER_SCHEDULE if i <= target]
    evaluated = {e.iteration for e in store.evaluations(entry.run)}
    if record.iterations >= target and all(i in evaluated for i in points):
        return f"at {record.iterations}"
    session = runs.restore_session(store, record)
    start = session.iteration
    with _locked(store, entry.run) as outcome:
        for point in points:
            if session.iteration < point and not should_stop():
                runs.train(store, entry.run, session, point, should_stop=should_stop,
                           owner=outcome["owner"])
            if session.iteration == point:
                learner_measures(session, store, entry.run)
        done = session.iteration >= entry.cap
        outcome["status"] = RunStatus.FINISHED if done else RunStatus.PAUSED
    return f"{start} → {session.iteration} ({outcome['status'].value})"


Job = GridEntry | LearnerEntry


def ordered_jobs(variants: Iterable[Variant], seeds: Iterable[int]) -> list[Job]:
    """The grid's order within a stage: task by task, each algorithm and reward with its
    variants side by side (paper, then fixed), seeds last; the learner's first seed after
    move-robot's q-learning (cheap, and the figure's reference), its others after
    move-robot."""
    seeds = tuple(seeds)
    variants = tuple(variants)
    entries = claimed_entries(variants, seeds)
    jobs: list[Job] = []
    for task in TASKS:
        mine = [e for e in entries if e.task == task]
        kinds = dict.fromkeys((e.algorithm, e.reward) for e in mine)
        for algorithm, reward in kinds:
            jobs += [e for v in variants for e in mine
                     if (e.algorithm, e.reward, e.variant) == (algorithm, reward, v)]
            if task == "move-robot" and algorithm == "q-learning" and reward == "guided":
                jobs.append(LearnerEntry(seeds[0]))
        if task == "move-robot":
            jobs += [LearnerEntry(seed) for seed in seeds[1:]]
    return jobs


def run_grid(store, jobs: list[Job], should_stop: Callable[[], bool],
             log: Callable[[str], None], stages: Iterable[int] = STAGES) -> None:
    """Every job to each stage's iterations in turn (capped), skipping what is done."""
    import torch

    torch.set_num_threads(1)
    claim(store, jobs)
    for stage in stages:
        log(f"stage {stage}")
        for job in jobs:
            if should_stop():
                log("stopping: every run is at its last checkpoint")
                return
            drive = run_learner if isinstance(job, LearnerEntry) else run_entry
            log(f"{job.run}: {drive(store, job, min(stage, job.cap), should_stop, log)}")
    log("grid done")
