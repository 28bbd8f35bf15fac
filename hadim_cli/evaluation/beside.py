"""Periodic evaluations run beside training, each in a process of its own.

An evaluation reads the learner and changes nothing in it (the controller draws no random
numbers; each task's world is its own), so it can run on a copy: at each evaluation point the
training process forks, the child evaluates the learner as it was at that iteration and
sends the scores back through a pipe, and training goes on meanwhile on the other core. The
results are those an evaluation in the training process would give, bit for bit; they are
handed over in the order they were started, each with the iteration it measured. At most one
evaluation is under way: the next waits for it, so a slow evaluation slows training down
rather than piling up copies of the learner.

The child ignores Ctrl-C (the terminal sends it to the whole process group): the training
process decides what an interruption means, and waits for the evaluation under way before it
stops, so that every evaluation point reached is stored.
"""

from __future__ import annotations

import multiprocessing
import signal
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Any

from hadim_cli.errors import HadimError

if TYPE_CHECKING:
    from hadim_cli.session import Session


@dataclass(frozen=True)
class Scored:
    """One task's evaluation at one iteration: its score and its points (`TaskResult`'s
    `to_dict()["points"]`)."""

    iteration: int
    task: str
    score: float
    points: list[dict[str, Any]]


def _evaluate(conn: Connection, session: Session, tasks: tuple[str, ...]) -> None:
    """The child: evaluate and send [(task, score, points)] or ("error", message)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        from hadim_cli.runs import evaluate_tasks

        conn.send(("ok", [(name, result.score, result.to_dict()["points"])
                          for name, result in evaluate_tasks(session, tasks).items()]))
    except BaseException as exc:  # the parent reports it: one line, not a child's traceback
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


class Evaluations:
    """Evaluations of a session's learner started at chosen iterations, run beside it."""

    def __init__(self, session: Session, tasks: tuple[str, ...],
                 on_result: Callable[[Scored], None]):
        self.session = session
        self.tasks = tasks
        self.on_result = on_result
        self._context = multiprocessing.get_context("fork")
        self._running: tuple[int, Any, Connection] | None = None

    def start(self) -> None:
        """Evaluate the learner as it is now (waiting first for the evaluation under way)."""
        self.finish()
        receive, send = self._context.Pipe(duplex=False)
        child = self._context.Process(target=_evaluate, args=(send, self.session, self.tasks),
                                      daemon=True)
        child.start()
        send.close()
        self._running = (self.session.iteration, child, receive)

    def poll(self) -> None:
        """Hand over the evaluation under way if it is done."""
        if self._running is not None and self._running[2].poll():
            self.finish()

    def finish(self) -> None:
        """Wait for the evaluation under way, if any, and hand its results over."""
        if self._running is None:
            return
        iteration, child, receive = self._running
        self._running = None
        try:
            status, payload = receive.recv()
        except EOFError:
            child.join()
            raise HadimError(f"the evaluation at iteration {iteration} ended without a result "
                             f"(exit code {child.exitcode})") from None
        finally:
            receive.close()
        child.join()
        if status != "ok":
            raise HadimError(f"the evaluation at iteration {iteration} failed: {payload}")
        for task, score, points in payload:
            self.on_result(Scored(iteration, task, score, points))

    def close(self) -> None:
        """Stop an evaluation under way without its results (after an error)."""
        if self._running is not None:
            _, child, receive = self._running
            self._running = None
            child.kill()
            child.join()
            receive.close()
