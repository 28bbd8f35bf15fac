"""The long RL grid of issue 46 (`hadim_cli.baselines.grid`), one process, resumable.

    nice -n 19 python scripts/rl_grid.py --store /work/rl/rl.sqlite \
        >> /work/rl/grid.log 2>&1 &                        # start, or continue where it stood
    nice -n 19 python scripts/rl_grid.py --store /work/rl/rl.sqlite --variant paper,fixed
    python scripts/rl_grid.py --store /work/rl/rl.sqlite --status   # where each entry stands

Idempotent: every entry is a run of the store named `g-TASK-ALGO-REWARD-VARIANT-sSEED`; the
script skips what is done (learned, or at the stage's iterations), continues the rest from their
last checkpoint (at most `grid.CHUNK` iterations are lost to a kill), creates what is missing.
SIGINT or SIGTERM stops it at the next checkpoint with every run paused and unlocked. Run one
at a time: the machine is shared.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time


def _log(message: str) -> None:
    print(f"{time.strftime('%Y-%m-%d %H:%M:%S')} {message}", flush=True)


def _status(store, entries) -> None:
    from hadim_cli.baselines.grid import LearnerEntry, learned_at

    names = {r.name: r for r in store.list_runs()}
    for entry in entries:
        record = names.get(entry.run)
        if record is None:
            print(f"{entry.run:42} not started")
            continue
        at = None if isinstance(entry, LearnerEntry) else learned_at(store, entry)
        state = f"learned at {at}" if at is not None else record.status
        print(f"{entry.run:42} {record.iterations:>8} / {entry.cap}  {state}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--store", required=True, help="SQLite file (created if missing).")
    parser.add_argument("--variant", default="paper",
                        help="Comma-separated variants, in order (paper, fixed).")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--status", action="store_true", help="Print where each entry stands.")
    args = parser.parse_args(argv)

    from hadim_cli.baselines.grid import ordered_jobs, run_grid
    from hadim_cli.baselines.variants import Variant
    from hadim_store.api import Store

    variants = [Variant(v) for v in args.variant.split(",")]
    entries = ordered_jobs(variants, [int(s) for s in args.seeds.split(",")])
    stop = {"now": False}

    def handler(signum, frame):  # noqa: ARG001
        stop["now"] = True
        _log(f"signal {signum}: stopping at the next checkpoint")

    with Store.open(args.store, create=not args.status) as store:
        if args.status:
            _status(store, entries)
            return 0
        signal.signal(signal.SIGINT, handler)
        signal.signal(signal.SIGTERM, handler)
        _log(f"grid of {len(entries)} runs into {args.store}")
        run_grid(store, entries, lambda: stop["now"], _log)
    return 0


if __name__ == "__main__":
    sys.exit(main())
