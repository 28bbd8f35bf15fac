"""A long learning session, measured: `hadim train` (or `hadim resume`) under a sampler.

    python scripts/long_session.py --store long.sqlite --iterations 100000   # run / resume
    python scripts/long_session.py --store long.sqlite --report              # the tables
    python scripts/long_session.py --store long.sqlite --report --plot long.png   # + figure
    python scripts/long_session.py --store copy.sqlite --delta-bytes 50000   # a delta's bytes

Runs the session named `--name` (default `long`, seed 0, default config, evaluation every
`--eval-every` iterations) in a child process, resuming it if the store already has it, and
every `--sample-every` seconds appends to `<store>.samples.jsonl` the run's stored iterations,
the store's bytes on disk and the child's resident memory. Stopping this script (Ctrl-C) stops
the child after its episode; run it again to continue.

`--report` prints, per block of `--block` iterations: iterations per second (from the
checkpoints' timestamps, one per episode, leaving out episodes that include an evaluation or
a pause between sessions), iterations per CPU-second of the training process (from the
samples, leaving out intervals with an evaluation: on a shared machine wall-clock rates
follow the machine's load, CPU rates much less), the bytes the run has stored by the block's
end (from the tables, so a fork or another run in the file does not count) and per iteration,
the largest resident memory sampled in the block, the number of affordances, and the
evaluation scores. `--plot PNG` also draws them against iterations (rates and sizes per block
of `--plot-block`, memory and the file's size as sampled, scores at each evaluation).

`--time-restore [--at T]` restores the run's checkpoint at or before T (the last if not given)
as `hadim resume` does, without writing anything (a store of an older schema is refused, not
upgraded: a session of an older hadim may be writing to it; time an upgraded copy), and
prints the seconds to import torch (which any hadim process pays once), to read the
checkpoint and D and rebuild the learner (and the CPU seconds of that, which a loaded machine
changes little), and from there to the first new iteration. With `--then N` it goes on for N
iterations (whole episodes, nothing stored) and prints their wall and CPU seconds: the cost
per iteration at that point of the run, measured in CPU time, which a shared machine's load
changes little; and D's digest at the end and that of the new rows alone. `--profile PROF`
also writes a cProfile of those N iterations, timed in CPU seconds (the profiler's overhead
is in the printed CPU seconds then: compare profiles with profiles).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path
from typing import NamedTuple

_GAP_S = 300.0
"""An episode longer than this spans a pause between two sessions: not timed."""


def _file_bytes(path: Path) -> int:
    """The SQLite file and its companions (not the samples or a figure written beside it)."""
    files = (Path(str(path) + suffix) for suffix in ("", "-wal", "-shm", "-journal"))
    return sum(p.stat().st_size for p in files if p.is_file())


def _rss(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/status") as handle:
            for line in handle:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process so far (0 if unreadable)."""
    try:
        with open(f"/proc/{pid}/stat") as handle:
            fields = handle.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return 0.0


def _connect(store: Path) -> sqlite3.Connection:
    return sqlite3.connect(f"{store.resolve().as_uri()}?mode=ro", uri=True)


def _iterations(store: Path, name: str) -> int:
    try:
        con = _connect(store)
        try:
            row = con.execute("SELECT iterations FROM runs WHERE name = ?", (name,)).fetchone()
        finally:
            con.close()
    except sqlite3.Error:
        return 0
    return int(row[0]) if row else 0


def run(args: argparse.Namespace) -> None:
    store, name = Path(args.store), args.name
    exists = store.exists() and _iterations(store, name) > 0
    cli = [sys.executable, "-m", "hadim_cli.app"]
    if exists:
        cmd = [*cli, "resume", name, "--iterations", str(args.iterations)]
    else:
        cmd = [*cli, "train", "--name", name, "--seed", str(args.seed),
               "--iterations", str(args.iterations)]
        cmd += [x for setting in args.set for x in ("--set", setting)]
    cmd += ["--eval-every", str(args.eval_every), "--store", str(store)]
    child = subprocess.Popen(["nice", "-n", str(args.nice), *cmd])
    log = Path(str(store) + ".samples.jsonl")

    def pause(_signum, _frame) -> None:  # the child checkpoints after its episode and stops
        child.send_signal(signal.SIGINT)

    # Installed explicitly: a script started in the background inherits SIGINT ignored.
    signal.signal(signal.SIGINT, pause)
    signal.signal(signal.SIGTERM, pause)
    while child.poll() is None:
        sample = {"time": time.time(), "iterations": _iterations(store, name),
                  "store_bytes": _file_bytes(store), "rss_bytes": _rss(child.pid),
                  "cpu_s": _cpu_seconds(child.pid), "pid": child.pid}
        with log.open("a") as handle:
            handle.write(json.dumps(sample) + "\n")
        time.sleep(args.sample_every)
    sys.exit(child.returncode)


def _stored_bytes(con: sqlite3.Connection, run_id: int, upto: int) -> int:
    """Bytes of the run's rows stored by iteration `upto` (blobs and texts)."""
    q = [
        ("SELECT sum(length(actions) + length(contexts) + length(outcomes) + length(extra_json))"
         " FROM episodes WHERE run_id = ? AND first_iteration + n_iterations <= ?"),
        ("SELECT sum(coalesce(length(i.data), 0) + coalesce(length(i.text), 0) + length(i.key))"
         " FROM checkpoint_items i JOIN checkpoints c ON c.id = i.checkpoint_id"
         " WHERE c.run_id = ? AND c.iteration <= ?"),
        ("SELECT sum(length(context_json) + length(detail_json) + 64) FROM affordance_events"
         " WHERE run_id = ? AND iteration <= ?"),
        "SELECT count(*) * 48 FROM affordance_stats WHERE run_id = ? AND iteration <= ?",
        ("SELECT sum(length(low_json) + length(high_json) + 56) FROM interest_regions"
         " WHERE run_id = ? AND iteration <= ?"),
    ]
    return sum(int(con.execute(sql, (run_id, upto)).fetchone()[0] or 0) for sql in q)


class Sample(NamedTuple):
    """One line of `<store>.samples.jsonl`."""

    time: float
    iterations: int
    store_bytes: int
    rss_bytes: int
    cpu_s: float
    pid: int | None


class Block(NamedTuple):
    """What the report says of iterations [start, stop)."""

    start: int
    stop: int
    iterations_per_s: float | None
    iterations_per_cpu_s: float | None
    stored_bytes: int
    bytes_per_iteration: float
    rss_bytes: int
    affordances: int
    scores: dict[str, float]


class Record(NamedTuple):
    """A long session as stored: checkpoint times, evaluations, samples."""

    name: str
    run_id: int
    iterations: int
    stamps: list[tuple[int, datetime]]
    evals: dict[int, dict[str, float]]
    samples: list[Sample]
    hierarchy: list[tuple[int, int]]  # (iteration, |H|) at each episode's end


def read_record(con: sqlite3.Connection, store: Path, name: str) -> Record:
    row = con.execute("SELECT id, iterations FROM runs WHERE name = ?", (name,)).fetchone()
    if row is None:
        sys.exit(f"error: no run named {name!r} in {store}")
    run_id, total = row
    stamps = [(it, datetime.fromisoformat(str(at))) for it, at in con.execute(
        "SELECT iteration, created_at FROM checkpoints WHERE run_id = ? ORDER BY iteration",
        (run_id,))]
    evals: dict[int, dict[str, float]] = {}
    for it, task, score in con.execute(
            "SELECT iteration, task, score FROM evaluations WHERE run_id = ?", (run_id,)):
        evals.setdefault(it, {})[task] = score
    log = Path(str(store) + ".samples.jsonl")
    lines = log.read_text().splitlines() if log.exists() else []
    samples = [Sample(**{k: v for k, v in json.loads(x).items() if k in Sample._fields})
               for x in lines if x.strip()]
    hierarchy = [(int(it), int(n)) for it, n in con.execute(
        "SELECT iteration, count(*) FROM affordance_stats WHERE run_id = ? GROUP BY iteration "
        "ORDER BY iteration", (run_id,))]
    return Record(name, run_id, int(total), stamps, evals, samples, hierarchy)


def _wall_rate(r: Record, lo: int, hi: int) -> float | None:
    """Iterations per second between checkpoints in [lo, hi], without evaluations or pauses."""
    secs, its = 0.0, 0
    for (i0, t0), (i1, t1) in zip(r.stamps, r.stamps[1:], strict=False):
        if lo <= i0 and i1 <= hi:
            dt = (t1 - t0).total_seconds()
            if dt < _GAP_S and not any(i0 <= e < i1 for e in r.evals):
                secs, its = secs + dt, its + (i1 - i0)
    return its / secs if secs else None


def _progress(samples: list[Sample]) -> list[Sample]:
    """The samples at which a process's stored iterations had moved since its previous sample:
    between two of them, its CPU went to those iterations (and to an evaluation, if one ran).
    A process's first sample, before its first new iteration, is left out: that is its start
    (imports, restore)."""
    last: dict[int | None, int] = {}
    out = []
    for x in samples:
        if x.pid in last and x.iterations > last[x.pid]:
            out.append(x)
        last[x.pid] = x.iterations
    return out


def _cpu_rate(r: Record, lo: int, hi: int) -> float | None:
    """Iterations per CPU-second of the training process over [lo, hi]: the intervals between
    progress samples of one process whose middle falls in the block, leaving out those next to
    an evaluation (it runs right after its iteration is stored)."""
    cpu, its = 0.0, 0
    moved = _progress(r.samples)
    for a, b in zip(moved, moved[1:], strict=False):
        evaluated = any(a.iterations <= e <= b.iterations for e in r.evals)
        if a.pid == b.pid and lo <= (a.iterations + b.iterations) / 2 < hi and not evaluated:
            cpu, its = cpu + b.cpu_s - a.cpu_s, its + b.iterations - a.iterations
    return its / cpu if cpu > 0 else None


def blocks(con: sqlite3.Connection, r: Record, pairs: list[tuple[int, int]]) -> list[Block]:
    rows = []
    for lo, hi in pairs:
        rss = max((s.rss_bytes for s in r.samples if lo < s.iterations <= hi), default=0)
        (n_aff,) = con.execute(
            "SELECT count(*) FROM affordance_stats WHERE run_id = ? AND iteration = (SELECT "
            "max(iteration) FROM affordance_stats WHERE run_id = ? AND iteration <= ?)",
            (r.run_id, r.run_id, hi)).fetchone()
        stored = _stored_bytes(con, r.run_id, hi)
        rows.append(Block(lo, hi, _wall_rate(r, lo, hi), _cpu_rate(r, lo, hi), stored,
                          stored / max(hi, 1), rss, int(n_aff), r.evals.get(hi, {})))
    return rows


def _edges(total: int, block: int) -> list[tuple[int, int]]:
    edges = sorted({*range(0, total + 1, block), total})
    return list(zip(edges, edges[1:], strict=False))


_TASKS = ("move-robot", "push-object", "push-with-tool")


def _table(rows: list[Block], file_bytes: int) -> None:
    print("| iterations | it/s (wall) | it/CPU-s | stored MB | bytes/it | RSS MB | H | "
          "move / push / tool |")
    print("|---|---|---|---|---|---|---|---|")
    for b in rows:
        scores = " / ".join(f"{b.scores[t]:.3f}" for t in _TASKS if t in b.scores) or "–"
        ips = f"{b.iterations_per_s:.1f}" if b.iterations_per_s else "–"
        cps = f"{b.iterations_per_cpu_s:.1f}" if b.iterations_per_cpu_s else "–"
        print(f"| {b.start}–{b.stop} | {ips} | {cps} | {b.stored_bytes / 1e6:.1f} | "
              f"{b.bytes_per_iteration:.0f} | {b.rss_bytes / 1e6:.0f} | "
              f"{b.affordances} | {scores} |")
    print(f"file on disk: {file_bytes / 1e6:.1f} MB")


def figure(r: Record, fine: list[Block], out: Path) -> None:
    """Five panels against iterations: iterations per second (per block of `fine`: wall and per
    CPU-second), the store's size (the file and its WAL, sampled; the run's rows, per block),
    resident memory (sampled), the evaluation scores, and the number of affordances."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (rate, size, mem, score, count) = plt.subplots(
        5, 1, figsize=(8, 11), sharex=True, gridspec_kw={"height_ratios": [3, 3, 2, 3, 1.5]})
    mid = [(b.start + b.stop) / 2 for b in fine]
    for key, label in (("iterations_per_s", "wall (shared machine)"),
                       ("iterations_per_cpu_s", "per CPU-second of the process")):
        y = [getattr(b, key) if getattr(b, key) is not None else float("nan") for b in fine]
        rate.plot(mid, y, marker=".", label=label)
    rate.set_ylabel("iterations / s")
    rate.legend()
    size.plot([s.iterations for s in r.samples], [s.store_bytes / 1e6 for s in r.samples],
              label="file + WAL on disk (sampled)")
    size.plot([b.stop for b in fine], [b.stored_bytes / 1e6 for b in fine], ".",
              label="the run's rows")
    size.set_ylabel("store MB")
    size.legend()
    for pid in dict.fromkeys(s.pid for s in r.samples):  # one line per process
        run = [s for s in _progress(r.samples) if s.pid == pid]
        mem.plot([s.iterations for s in run], [s.rss_bytes / 1e6 for s in run], color="C0")
    mem.set_ylabel("resident MB")
    at = sorted(r.evals)
    for task in _TASKS:
        pts = [(i, r.evals[i][task]) for i in at if task in r.evals[i]]
        score.plot([i for i, _ in pts], [v for _, v in pts], marker="o", label=task)
    score.set_ylabel("evaluation score")
    score.set_ylim(-0.02, 1.02)
    score.legend(loc="lower right", fontsize="small")
    count.step([it for it, _ in r.hierarchy], [n for _, n in r.hierarchy], where="post",
               color="grey")
    count.yaxis.get_major_locator().set_params(integer=True)
    count.set_ylabel("|H|")
    count.set_xlabel("iteration")
    for ax in (rate, size, mem, count):
        ax.set_ylim(bottom=0)
    for ax in (rate, size, mem, score, count):
        ax.grid(alpha=0.3)
    fig.suptitle(f"long session {r.name!r}: {r.iterations} iterations")
    fig.tight_layout()
    try:
        fig.savefig(out, dpi=110)
    finally:
        plt.close(fig)


def report(args: argparse.Namespace) -> None:
    store = Path(args.store)
    if not store.is_file():
        sys.exit(f"error: no store at {store}")
    con = _connect(store)
    try:
        r = read_record(con, store, args.name)
        extra = args.extra_blocks
        pairs = _edges(r.iterations, args.block) + [
            (lo, hi) for lo, hi in zip(extra[::2], extra[1::2], strict=False)
            if hi <= r.iterations]
        rows = blocks(con, r, pairs)
        if args.plot:
            figure(r, blocks(con, r, _edges(r.iterations, args.plot_block)), Path(args.plot))
    finally:
        con.close()
    if args.json:
        print(json.dumps({"run": r.name, "iterations": r.iterations,
                          "file_bytes": _file_bytes(store),
                          "blocks": [b._asdict() for b in rows]}))
    else:
        _table(rows, _file_bytes(store))


def time_restore(args: argparse.Namespace) -> None:
    t0 = time.perf_counter()
    # Timed apart: every process that trains p_A pays it once (Adam imports torch._dynamo).
    import torch._dynamo  # noqa: F401

    from hadim_cli import runs
    from hadim_store import SchemaError, Store

    t1, c1 = time.perf_counter(), time.process_time()
    try:
        # Not even an upgrade: a session may be writing to this store with an older hadim.
        opened = Store.open(args.store, create=False, upgrade=False)
    except SchemaError as exc:
        sys.exit(f"error: {exc} (time a copy of it: `hadim store upgrade` upgrades the copy)")
    with opened as store:
        session = runs.restore_session(store, store.get_run(args.name), args.at)
    t2, c2 = time.perf_counter(), time.process_time()
    first: list[float] = []
    step = session.world.step

    def timed(action):
        out = step(action)
        first.append(time.perf_counter())
        return out

    session.world.step = timed
    start = session.iteration
    d = session.learner.dataset
    profiler = None
    if args.profile:
        import cProfile

        # CPU time, not wall: on a shared machine the wall clock measures the others' jobs.
        profiler = cProfile.Profile(time.process_time)
        profiler.enable()
    c0, w0 = time.process_time(), time.perf_counter()
    session.run(start + max(args.then, 1))  # at least one episode
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if profiler is not None:
        profiler.disable()
        profiler.dump_stats(args.profile)
    done = session.iteration - start
    print(json.dumps({"iteration": start, "import_torch_s": round(t1 - t0, 2),
                      "restore_s": round(t2 - t1, 2), "restore_cpu_s": round(c2 - c1, 2),
                      "first_iteration_s": round(first[0] - t2, 2),
                      "restore_to_first_iteration_s": round(first[0] - t1, 2),
                      "then_iterations": done, "then_wall_s": round(wall, 2),
                      "then_cpu_s": round(cpu, 2),
                      "iterations_per_cpu_s": round(done / max(cpu, 1e-9), 1),
                      # D's digest (Store.dataset_sha256's) at the end, and of the new rows
                      # alone: the same code gives the same rows, whatever the load.
                      "dataset_sha256": _digest(d.actions, d.contexts, d.outcomes),
                      "new_rows_sha256": _digest(d.actions[start:], d.contexts[start:],
                                                 d.outcomes[start:])}))


def _digest(*arrays) -> str:
    """`Store.dataset_sha256` of these arrays of D (actions, contexts, outcomes)."""
    from hadim_store.dataset import DatasetArrays, digest

    return digest(DatasetArrays(*arrays))


def delta_bytes(args: argparse.Namespace) -> None:
    """Per checkpoint T of `--delta-bytes`: the bytes it holds in the store (as the hadim that
    wrote it encoded it) and those this hadim writes for the same checkpoint as a delta on the
    run's checkpoint before it (p_A's replay items apart: the part a full replay rewrote)."""
    from datetime import UTC

    from hadim_store import SchemaError, Store, codecs, deltas

    try:
        opened = Store.open(args.store, create=False, upgrade=False)
    except SchemaError as exc:
        sys.exit(f"error: {exc} (measure a copy of it: `hadim store upgrade` upgrades the copy)")
    with opened as store:
        its = store.checkpoint_iterations(args.name)
        con = _connect(Path(args.store))
        try:
            for at in args.delta_bytes:
                if at not in its or its.index(at) == 0:
                    sys.exit(f"error: run {args.name!r} has no checkpoint at {at} after another")
                before = store.checkpoint(args.name, its[its.index(at) - 1])
                now = store.checkpoint(args.name, at)
                stored = con.execute(
                    "SELECT i.key, coalesce(length(i.data), 0) + coalesce(length(i.text), 0) "
                    "FROM checkpoint_items i JOIN checkpoints c ON c.id = i.checkpoint_id "
                    "JOIN runs r ON r.id = c.run_id WHERE r.name = ? AND c.iteration = ?",
                    (args.name, at)).fetchall()
                base = deltas.LastWritten(
                    datetime.now(UTC), -1, before.iteration, dict(before.arrays),
                    {k: [codecs.encode_json(e) for e in v] for k, v in before.json.items()
                     if isinstance(v, list)}, {})
                rows, *_ = deltas.encode(now.arrays, now.json, compress=True, base=base)
                replay = lambda pairs: sum(n for k, n in pairs if ".replay." in k)  # noqa: E731
                print(json.dumps({
                    "iteration": at, "base_iteration": before.iteration,
                    "stored_bytes": sum(n for _, n in stored), "stored_replay_bytes":
                    replay(stored), "delta_bytes": sum(r.size for r in rows),
                    "delta_replay_bytes": replay([(r.key, r.size) for r in rows])}))
        finally:
            con.close()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--store", required=True)
    p.add_argument("--name", default="long")
    p.add_argument("--iterations", type=int, default=100_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--eval-every", type=int, default=5000)
    p.add_argument("--sample-every", type=float, default=20.0)
    p.add_argument("--nice", type=int, default=10)
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="a config override of a new session (a resumed one keeps its config)")
    p.add_argument("--report", action="store_true")
    p.add_argument("--block", type=int, default=5000)
    p.add_argument("--extra-blocks", type=int, nargs="*", default=[3500, 4000, 45000, 50000],
                   help="more blocks to report, as start stop pairs")
    p.add_argument("--json", action="store_true")
    p.add_argument("--plot", default=None, metavar="PNG",
                   help="with --report: also draw the figure (docs/performance.md)")
    p.add_argument("--plot-block", type=int, default=1000,
                   help="the figure's rates and sizes per block of this many iterations")
    p.add_argument("--time-restore", action="store_true")
    p.add_argument("--at", type=int, default=None)
    p.add_argument("--then", type=int, default=0)
    p.add_argument("--profile", default=None, metavar="PROF",
                   help="with --time-restore: a cProfile (CPU timer) of the new iterations, "
                        "to read with pstats")
    p.add_argument("--delta-bytes", type=int, nargs="+", default=None, metavar="T",
                   help="bytes of the checkpoint at T as stored and as this hadim's delta")
    args = p.parse_args()
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    (report if args.report else time_restore if args.time_restore
     else delta_bytes if args.delta_bytes else run)(args)


if __name__ == "__main__":
    main()
