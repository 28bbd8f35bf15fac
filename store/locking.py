"""When a run's lock may be taken over: its holder is dead or has stopped beating."""

from __future__ import annotations

import os
import socket
import time
from dataclasses import dataclass
from datetime import UTC, datetime

from hadim_store.records import LockInfo

DEFAULT_TIMEOUT_S = 60.0
"""A lock whose holder has not beaten for this long may be taken over."""


@dataclass(frozen=True)
class Holder:
    owner: str
    pid: int
    host: str
    heartbeat: float


def holder(owner: str | None, pid: int | None, host: str | None,
           heartbeat: float | None) -> Holder | None:
    """The holder a run's lock columns record; None when the run is not locked."""
    if owner is None:
        return None
    return Holder(owner=owner, pid=pid or 0, host=host or "", heartbeat=heartbeat or 0.0)


def lock_info(holder: Holder) -> LockInfo:
    return LockInfo(holder.owner, holder.pid, holder.host,
                    datetime.fromtimestamp(holder.heartbeat, UTC))


def describe(holder: Holder) -> str:
    age = time.time() - holder.heartbeat
    return (
        f"locked by pid {holder.pid} on {holder.host} (owner {holder.owner!r}, "
        f"last heartbeat {age:.0f} s ago)"
    )


def this_host() -> str:
    return socket.gethostname()


def pid_alive(pid: int) -> bool:
    """Whether a process with this id exists on this host (a zombie counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:
        return True  # cannot tell: assume alive rather than steal a live lock
    return True


def stale_reason(holder: Holder, *, timeout_s: float, now: float | None = None) -> str | None:
    """Why ``holder``'s lock is stale, or None if it may still be live."""
    now = time.time() if now is None else now
    if holder.host == this_host() and not pid_alive(holder.pid):
        return f"pid {holder.pid} on {holder.host} is not running"
    age = now - holder.heartbeat
    if age > timeout_s:
        return f"no heartbeat for {age:.0f} s (timeout {timeout_s:g} s)"
    return None
