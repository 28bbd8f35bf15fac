"""What `train` and `resume` tell the user while and after they run: a progress bar with an ETA
on a terminal, a progress line every tenth of the job otherwise, and a closing summary.

Everything goes to stderr through `say`, which survives a reader that went away: with
`hadim train 2>&1 | tee log`, Ctrl-C kills `tee` too, and the message that says how to resume
must still reach the user (on the terminal) without turning a clean pause into a crash.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hadim_cli.runs import Progress

LINES = 10
"""Without a terminal, one progress line per tenth of the iterations to run."""


def say(text: str) -> None:
    """Write a line to stderr; if that pipe is broken, to the controlling terminal; never
    raise. After a broken pipe, stderr and stdout point at /dev/null, so that Python's final
    flush cannot fail and turn the exit status into 120."""
    if not _broken:
        try:
            sys.stderr.write(text + "\n")
            sys.stderr.flush()
            return
        except (BrokenPipeError, OSError, ValueError):
            _silence_broken_streams()
    try:
        with open("/dev/tty", "w") as tty:
            tty.write(text + "\n")
    except OSError:
        pass  # no terminal either (e.g. under nohup): the run's status is in the store


_broken: list[bool] = []
"""Non-empty once stderr's reader has gone: later lines go to the terminal directly."""


def _silence_broken_streams() -> None:
    _broken.append(True)
    devnull = os.open(os.devnull, os.O_WRONLY)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            os.dup2(devnull, stream.fileno())
    os.close(devnull)


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes} min {seconds:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def scores_text(scores: dict[str, float], at: int | None) -> str:
    if not scores or at is None:
        return ""
    return " ".join(f"{k}={v:.2f}" for k, v in scores.items()) + f" (at {at})"


class Reporter:
    """A rich progress bar with an ETA on a terminal; plain lines every tenth otherwise."""

    def __init__(self, run: str, start: int, total: int):
        from rich.console import Console

        self.run, self.start, self.total = run, start, total
        self.console = Console(stderr=True)
        self.terminal = self.console.is_terminal
        self.began = time.monotonic()
        self._next_line = 1
        self._bar = None

    def __enter__(self) -> Reporter:
        if self.terminal:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self._bar = Progress(
                TextColumn("[bold]{task.fields[run]}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("{task.fields[info]}"), TimeElapsedColumn(), TextColumn("ETA"),
                TimeRemainingColumn(), console=self.console, transient=False)
            self._bar.__enter__()
            self._task = self._bar.add_task("train", total=self.total, completed=self.start,
                                            run=self.run, info="")
        else:
            say(f"{self.run}: training from iteration {self.start} to {self.total}")
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc_info)

    def update(self, p: Progress) -> None:
        size = "" if p.affordances is None else f"H={p.affordances} "
        info = f"{size}{scores_text(p.scores, p.scored_at)}".strip()
        if self._bar is not None:
            self._bar.update(self._task, completed=p.iteration, info=info)
            return
        todo = max(self.total - self.start, 1)
        done = p.iteration - self.start
        if done * LINES >= self._next_line * todo or p.iteration >= self.total:
            self._next_line = done * LINES // todo + 1
            elapsed = time.monotonic() - self.began
            eta = elapsed / done * (self.total - p.iteration) if done > 0 else 0.0
            say(f"{self.run}: {p.iteration}/{self.total} iterations, {info}, "
                f"{_duration(elapsed)} elapsed, ETA {_duration(eta)}")


def summary(store, run: str, start: int, seconds: float, store_option: str | None) -> str:
    """The closing lines of `train`/`resume`: where the run stands and what to do next."""
    from hadim_cli.runs import store_location

    record = store.get_run(run)
    latest: dict[str, tuple[float, int]] = {}
    for e in store.evaluations(run):
        latest[e.task] = (e.score, e.iteration)
    n_aff = sum(1 for s in store.stats(run, upto_iteration=record.iterations)
                if s.iteration == record.iterations)
    from hadim_cli.commands.driver import further_command, resume_command
    from hadim_store.records import RunStatus

    where = store_location(store_option)
    size = _store_size(store, where)
    flag = f" --store {where}" if store_option else ""
    go_on = (further_command(run, record.iterations, store_option)
             if record.status is RunStatus.FINISHED else resume_command(run, store_option))
    done = record.iterations - start
    rate = f", {done / seconds:.0f} iterations/s" if seconds > 0 and done > 0 else ""
    scores = "; ".join(f"{task} {score:.3f} at {it}" for task, (score, it) in latest.items())
    return "\n".join([
        f"{run}: {record.status.value} at iteration {record.iterations} "
        f"({done} trained in {_duration(seconds)}{rate})",
        f"  affordances: {n_aff}",
        f"  scores: {scores or 'none (evaluation off)'}",
        f"  store: {where}" + (f" ({size / 1e6:.1f} MB)" if size is not None else ""),
        "  next:",
        f"    hadim runs show {run}{flag}",
        f"    hadim affordances {run}{flag}",
        f"    hadim plot {run} --out {run}.png{flag}",
        f"    {go_on}",
    ])


def _store_size(store, where: str) -> int | None:
    """The store file's size once its write-ahead log is checkpointed into it: what it
    occupies when no process has it open (the `-wal` file then goes)."""
    if "://" in where or not Path(where).is_file():
        return None
    store.flush_wal()
    return Path(where).stat().st_size
