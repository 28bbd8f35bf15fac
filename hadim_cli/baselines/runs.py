"""Baseline runs in the experiment store: created, trained chunk by chunk, restored.

A baseline run is a run like the learner's: its config is a `BaselineConfig` under
`kind = "baseline"`; each chunk of iterations (`chunk`, default 1000) is one stored episode
whose rows are the transitions it experienced (action = wheel command, context = the
observation and goal before, outcome = after − before; `extra` holds the rewards and where
environment episodes ended) and whose checkpoint holds the agent's state (see
`agents.SB3Agent.state`). Restoring rebuilds the agent from the run's seed and loads the
latest checkpoint, replaying the replay-buffer rows of every checkpoint up to it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import Any

import numpy as np

from hadim_cli.baselines.agents import make_agent
from hadim_cli.baselines.config import BaselineConfig, check_total, read_config
from hadim_cli.baselines.evaluate import evaluate_policy
from hadim_cli.errors import HadimError
from hadim_cli.evaluation.metric import measure_name
from hadim_cli.evaluation.runner import TaskResult
from hadim_cli.evaluation.tasks import Task, load_task
from hadim_cli.runs import TARGET_KEY, Progress, package_versions
from hadim_store.api import Store
from hadim_store.records import EpisodeWrite, RunRecord

STATE_FORMAT = 1


class BaselineSession:
    """One baseline agent, its run's seed, and the transitions of the chunk being run."""

    def __init__(self, cfg: BaselineConfig, seed: int):
        self.cfg = cfg
        self.seed = seed
        # One root generator: the agent's seed (SB3's, or Q-learning's generator) comes
        # from it, so a run's seed fixes everything.
        agent_seed = int(np.random.default_rng(seed).integers(2**31 - 1))
        self.agent = make_agent(cfg, agent_seed)
        self.chunks_done = 0
        self._rows: list[tuple] = []
        for env in self.agent.bases:  # rows in the order the vectorised env steps them
            env.recorder = self._record

    @property
    def iteration(self) -> int:
        return self.agent.iterations

    def _record(self, wheels, before, after, reward, terminated, truncated) -> None:
        self._rows.append((wheels, before, after, reward, terminated, truncated))

    def run_chunk(self, n: int) -> EpisodeWrite:
        """Learn `n` more iterations; what the store keeps of them."""
        start = self.iteration
        self._rows = []
        self.agent.learn(n)
        rows = self._rows
        if len(rows) != n or self.iteration != start + n:
            raise HadimError(f"the agent ran {len(rows)} steps for a chunk of {n}")
        before = np.stack([r[1] for r in rows])
        meta, arrays = self.agent.state()
        extra = {"columns": self.agent.base.columns, "rewards": [float(r[3]) for r in rows],
                 "ends": [[i, bool(r[4]), bool(r[5])] for i, r in enumerate(rows)
                          if r[4] or r[5]]}
        self.chunks_done += 1
        return EpisodeWrite(
            index=self.chunks_done - 1, first_iteration=start,
            actions=np.stack([r[0] for r in rows]), contexts=before,
            outcomes=np.stack([r[2] for r in rows]) - before, extra=extra,
            checkpoint_arrays=arrays,
            checkpoint_json={"format": STATE_FORMAT, "kind": "baseline", "agent": meta,
                             "chunks": self.chunks_done})

    def evaluate(self, task: Task) -> TaskResult:
        return evaluate_policy(self.agent, self.cfg, task)

    def measures(self, task: Task) -> tuple[TaskResult, TaskResult]:
        """The two measures of issue 46: the score within the task's budget, and the same
        points within an episode's length (stored as `task@episode_length`), whose share of
        points in the goal zone is the episode success."""
        episode = dataclasses.replace(task, budget=self.cfg.episode_length,
                                      name=measure_name(task.name, self.cfg.episode_length))
        return self.evaluate(task), self.evaluate(episode)


def versions() -> dict[str, str]:
    out = package_versions()
    for name in ("gymnasium", "stable-baselines3"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "unknown"
    return out


def new_run(store: Store, cfg: BaselineConfig, seed: int, name: str | None) -> RunRecord:
    return store.create_run(config=cfg.to_dict(), seed=seed, name=name, versions=versions())


def restore(store: Store, run: RunRecord, at: int | None = None) -> BaselineSession:
    """The run's agent as it stood at its checkpoint at or before `at` (latest if None)."""
    session = BaselineSession(read_config(run.config), run.seed)
    checkpoint = store.checkpoint(run.name, at)
    if checkpoint is None:
        return session
    meta: dict[str, Any] = checkpoint.json
    if meta.get("format") != STATE_FORMAT or meta.get("kind") != "baseline":
        raise HadimError(f"run {run.name}: checkpoint format {meta.get('format')!r} is not "
                         "supported by this hadim")
    chunks = [store.checkpoint(run.name, it).arrays
              for it in store.checkpoint_iterations(run.name) if it < checkpoint.iteration]
    chunks.append(checkpoint.arrays)
    try:
        session.agent.restore(meta["agent"], checkpoint.arrays, chunks)
    except (KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise HadimError(f"run {run.name}: checkpoint at {checkpoint.iteration} is unusable: "
                         f"{exc}") from None
    session.chunks_done = int(meta["chunks"])
    if session.iteration != checkpoint.iteration:
        raise HadimError(f"run {run.name}: checkpoint at {checkpoint.iteration} restored "
                         f"{session.iteration} iterations")
    return session


def evaluate_tasks(session: BaselineSession, tasks: tuple[str, ...]) -> dict[str, TaskResult]:
    return {name: session.evaluate(load_task(name)) for name in tasks}


def next_evaluation(it: int, eval_every: int, eval_at: Sequence[int]) -> int | None:
    """The first iteration after `it` evaluated at: a multiple of `eval_every` (0: none) or
    one of `eval_at`; None when there is none."""
    later = [e for e in eval_at if e > it]
    if eval_every:
        later.append((it // eval_every + 1) * eval_every)
    return min(later, default=None)


def train(store: Store | None, run: str | None, session: BaselineSession, total: int, *,
          eval_every: int = 0, tasks: tuple[str, ...] = (),
          on_progress: Callable[[Progress], None] | None = None,
          should_stop: Callable[[], bool] | None = None,
          owner: str | None = None) -> dict[str, float]:
    """Run `session` to `total` iterations chunk by chunk, storing each (when a store is
    given), evaluating every `eval_every` iterations and at the config's `eval_at`, both
    measures (`BaselineSession.measures`); the same contract as `runs.train`."""
    check_total(total, session.cfg.multiple)
    scores: dict[str, float] = {}
    loaded = [load_task(name) for name in tasks]
    eval_at = session.cfg.eval_at if tasks else ()
    while session.iteration < total:
        it = session.iteration
        n = min(session.cfg.chunk, total - it)
        due = next_evaluation(it, eval_every, eval_at)
        if due is not None:
            n = min(n, due - it)
        write = session.run_chunk(n)
        if store is not None and run is not None:
            write = dataclasses.replace(write, extra={**write.extra, TARGET_KEY: total})
            store.write_episode(run, write, owner=owner)
        it = session.iteration
        if it == due:
            for task in loaded:
                for result in session.measures(task):
                    scores[result.task] = result.score
                    if store is not None and run is not None:
                        store.add_evaluation(run, it, result.task, result.score,
                                             result.to_dict()["points"])
        if on_progress is not None:
            on_progress(Progress(it, total, None, dict(scores)))
        if should_stop and should_stop():
            break
    return scores
