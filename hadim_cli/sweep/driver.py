"""Submitting a sweep's entries as Ray tasks, watching them through the store, stopping cleanly.

The store is the source of truth for progress (each run's status and iterations), so the
display works the same for a local Ray instance and a cluster. Ctrl-C sets a flag that every
task reads after each episode: each run stores its episode, checkpoints and pauses. A second
Ctrl-C cancels the tasks at once (each run keeps every episode stored before).
"""

from __future__ import annotations

import logging
import os
import socket
from collections.abc import Callable
from dataclasses import dataclass, field

from hadim_cli.errors import HadimError
from hadim_cli.sweep.plan import SweepEntry, SweepPlan
from hadim_cli.sweep.worker import EntryResult, run_entry

# A task whose worker process dies (killed, out of memory) is retried from its checkpoint.
TASK_RETRIES = 3
POLL_S = 0.5
# Ray's own connect retries an address nothing listens on for minutes: probe it first.
CONNECT_TIMEOUT_S = 5.0


@dataclass(frozen=True)
class SweepStatus:
    """The sweep as the store shows it."""

    done: int
    running: int
    failed: int
    pending: int
    iterations: int
    total: int


@dataclass
class SweepOutcome:
    results: dict[str, EntryResult] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    stopped: bool = False
    aborted: bool = False


def status_of(store, plan: SweepPlan, errors: dict[str, str]) -> SweepStatus:
    stored = {r.name: r for r in store.list_runs()}
    counts = {"done": 0, "running": 0, "failed": 0, "pending": 0}
    iterations = 0
    for entry in plan.entries:
        record = stored.get(entry.run)
        iterations += min(record.iterations, entry.iterations) if record else 0
        if entry.run in errors or (record and record.status == "failed"):
            counts["failed"] += 1
        elif record and record.status == "finished" and record.iterations >= entry.iterations:
            counts["done"] += 1
        elif record and record.status == "running":
            counts["running"] += 1
        else:
            counts["pending"] += 1
    return SweepStatus(**counts, iterations=iterations,
                       total=sum(e.iterations for e in plan.entries))


def unfinished(store, plan: SweepPlan) -> list[SweepEntry]:
    """The entries whose run is not finished yet (a re-run sweep skips the others)."""
    stored = {r.name: r for r in store.list_runs()}
    return [e for e in plan.entries
            if not (e.run in stored and stored[e.run].status == "finished"
                    and stored[e.run].iterations >= e.iterations)]


def check_address(address: str) -> None:
    """Refuse a cluster address (HOST:PORT or ray://HOST:PORT) that nothing answers on; other
    forms (`auto`) are Ray's to resolve."""
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit():
        return
    try:
        with socket.create_connection((host.strip("[]"), int(port)), CONNECT_TIMEOUT_S):
            pass
    except OSError as exc:
        raise HadimError(f"cannot reach the Ray cluster at {address}: "
                         f"{exc.strerror or exc}") from None


def start_ray(address: str | None, num_cpus: int | None) -> None:
    import ray

    try:
        if address:
            ray.init(address=address, logging_level=logging.WARNING, log_to_driver=False)
        else:
            ray.init(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False,
                     logging_level=logging.WARNING, log_to_driver=False)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        lines = str(exc).strip().splitlines() or [type(exc).__name__]
        what = (f"connect to the Ray cluster at {address}" if address
                else "start a local Ray instance")
        raise HadimError(f"cannot {what}: {lines[0]}") from None


def _task(store_url: str, entry: SweepEntry, flag) -> EntryResult:
    import ray

    return run_entry(store_url, entry, lambda: ray.get(flag.is_set.remote()))


class _StopFlag:
    def __init__(self) -> None:
        self._set = False

    def set(self) -> None:
        self._set = True

    def is_set(self) -> bool:
        return self._set


def run_sweep(store, store_url: str, plan: SweepPlan, entries: list[SweepEntry],
              on_poll: Callable[[SweepStatus], None]) -> SweepOutcome:
    """Run `entries` as Ray tasks (Ray already started) until done, Ctrl-C, or a second one."""
    import ray

    flag = ray.remote(num_cpus=0)(_StopFlag).remote()
    task = ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(_task)
    refs = {task.remote(store_url, entry, flag): entry.run for entry in entries}
    outcome = SweepOutcome()
    try:
        _collect(refs, outcome, lambda: on_poll(status_of(store, plan, outcome.errors)))
    except KeyboardInterrupt:
        outcome.stopped = True
        ray.get(flag.set.remote())
        try:
            _collect(refs, outcome, lambda: on_poll(status_of(store, plan, outcome.errors)))
        except KeyboardInterrupt:
            outcome.aborted = True
            for ref in refs:
                ray.cancel(ref, force=True)
    on_poll(status_of(store, plan, outcome.errors))
    return outcome


def _collect(refs: dict, outcome: SweepOutcome, poll: Callable[[], None]) -> None:
    import ray

    pending = [r for r in refs if refs[r] not in outcome.results
               and refs[r] not in outcome.errors]
    while pending:
        ready, pending = ray.wait(pending, num_returns=len(pending), timeout=POLL_S)
        for ref in ready:
            try:
                result = ray.get(ref)
                outcome.results[result.run] = result
            except ray.exceptions.RayError as exc:
                lines = str(exc).strip().splitlines()
                outcome.errors[refs[ref]] = lines[-1] if lines else type(exc).__name__
        poll()
