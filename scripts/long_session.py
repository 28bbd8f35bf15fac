"""A long learning session, measured: `hadim train` (or `hadim resume`) under a sampler.

    python scripts/long_session.py --store long.sqlite --iterations 100000   # run / resume
    python scripts/long_session.py --store long.sqlite --report              # the tables

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
evaluation scores.

`--time-restore [--at T]` restores the run's checkpoint at or before T (the last if not given)
as `hadim resume` does, without writing anything, and prints the seconds to import torch
(which any hadim process pays once), to read the checkpoint and D and rebuild the learner, and
from there to the first new iteration. With `--then N` it goes on for N iterations (whole
episodes, nothing stored) and prints their wall and CPU seconds: the cost per iteration at
that point of the run, measured in CPU time, which a shared machine's load changes little.
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

_GAP_S = 300.0
"""An episode longer than this spans a pause between two sessions: not timed."""


def _file_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in path.parent.glob(path.name + "*")
               if p.is_file() and not p.name.endswith(".jsonl"))


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


def report(args: argparse.Namespace) -> None:
    store, name, block = Path(args.store), args.name, args.block
    con = _connect(store)
    run_id, total = con.execute("SELECT id, iterations FROM runs WHERE name = ?",
                                (name,)).fetchone()
    stamps = [(it, datetime.fromisoformat(str(at))) for it, at in con.execute(
        "SELECT iteration, created_at FROM checkpoints WHERE run_id = ? ORDER BY iteration",
        (run_id,))]
    evals = {}
    for it, task, score in con.execute(
            "SELECT iteration, task, score FROM evaluations WHERE run_id = ?", (run_id,)):
        evals.setdefault(it, {})[task] = score
    log = Path(str(store) + ".samples.jsonl")
    samples = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    edges = sorted({*range(0, total + 1, block), total})
    pairs = list(zip(edges, edges[1:], strict=False))
    extra = args.extra_blocks
    pairs += [(lo, hi) for lo, hi in zip(extra[::2], extra[1::2], strict=False) if hi <= total]
    rows = []
    for lo, hi in pairs:
        secs, its = 0.0, 0
        for (i0, t0), (i1, t1) in zip(stamps, stamps[1:], strict=False):
            if lo <= i0 and i1 <= hi:
                dt = (t1 - t0).total_seconds()
                if dt < _GAP_S and not any(i0 <= e < i1 for e in evals):
                    secs, its = secs + dt, its + (i1 - i0)
        rss = max((s["rss_bytes"] for s in samples if lo < s["iterations"] <= hi), default=0)
        cpu, cpu_its = 0.0, 0
        started: dict[int, int] = {}  # pid → iteration it resumed at: its restore is not timed
        for x in samples:
            started.setdefault(x.get("pid"), x["iterations"])
        for a, b in zip(samples, samples[1:], strict=False):
            same = a.get("pid") is not None and a.get("pid") == b.get("pid") \
                and a["iterations"] > started[a["pid"]]
            if same and lo <= a["iterations"] and b["iterations"] <= hi \
                    and not any(a["iterations"] <= e < b["iterations"] or e == a["iterations"]
                                for e in evals):
                cpu, cpu_its = cpu + b["cpu_s"] - a["cpu_s"], cpu_its + b["iterations"] \
                    - a["iterations"]
        n_aff = con.execute("SELECT count(*) FROM affordance_stats WHERE run_id = ? AND "
                            "iteration = (SELECT max(iteration) FROM affordance_stats WHERE "
                            "run_id = ? AND iteration <= ?)", (run_id, run_id, hi)).fetchone()[0]
        stored = _stored_bytes(con, run_id, hi)
        rows.append({"start": lo, "stop": hi, "iterations_per_s": its / secs if secs else None,
                     "iterations_per_cpu_s": cpu_its / cpu if cpu > 0 else None,
                     "stored_bytes": stored, "bytes_per_iteration": stored / max(hi, 1),
                     "rss_bytes": rss, "affordances": n_aff, "scores": evals.get(hi, {})})
    con.close()
    if args.json:
        print(json.dumps({"run": name, "iterations": total, "file_bytes": _file_bytes(store),
                          "blocks": rows}))
        return
    print("| iterations | it/s (wall) | it/CPU-s | stored MB | bytes/it | RSS MB | H | "
          "move / push / tool |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        s = r["scores"]
        scores = " / ".join(f"{s[t]:.3f}" for t in ("move-robot", "push-object",
                                                     "push-with-tool") if t in s) or "–"
        ips = f"{r['iterations_per_s']:.1f}" if r["iterations_per_s"] else "–"
        cps = f"{r['iterations_per_cpu_s']:.1f}" if r["iterations_per_cpu_s"] else "–"
        print(f"| {r['start']}–{r['stop']} | {ips} | {cps} | {r['stored_bytes'] / 1e6:.1f} | "
              f"{r['bytes_per_iteration']:.0f} | {r['rss_bytes'] / 1e6:.0f} | "
              f"{r['affordances']} | {scores} |")
    print(f"file on disk: {_file_bytes(store) / 1e6:.1f} MB")


def time_restore(args: argparse.Namespace) -> None:
    t0 = time.perf_counter()
    # Timed apart: every process that trains p_A pays it once (Adam imports torch._dynamo).
    import torch._dynamo  # noqa: F401

    from hadim_cli import runs
    from store import Store

    t1 = time.perf_counter()
    with Store.open(args.store, create=False) as store:
        session = runs.restore_session(store, store.get_run(args.name), args.at)
    t2 = time.perf_counter()
    first: list[float] = []
    step = session.world.step

    def timed(action):
        out = step(action)
        first.append(time.perf_counter())
        return out

    session.world.step = timed
    start = session.iteration
    c0, w0 = time.process_time(), time.perf_counter()
    session.run(start + max(args.then, 1))  # at least one episode
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    done = session.iteration - start
    print(json.dumps({"iteration": start, "import_torch_s": round(t1 - t0, 2),
                      "restore_s": round(t2 - t1, 2),
                      "first_iteration_s": round(first[0] - t2, 2),
                      "restore_to_first_iteration_s": round(first[0] - t1, 2),
                      "then_iterations": done, "then_wall_s": round(wall, 2),
                      "then_cpu_s": round(cpu, 2),
                      "iterations_per_cpu_s": round(done / max(cpu, 1e-9), 1)}))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--store", required=True)
    p.add_argument("--name", default="long")
    p.add_argument("--iterations", type=int, default=100_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--eval-every", type=int, default=5000)
    p.add_argument("--sample-every", type=float, default=20.0)
    p.add_argument("--nice", type=int, default=10)
    p.add_argument("--report", action="store_true")
    p.add_argument("--block", type=int, default=5000)
    p.add_argument("--extra-blocks", type=int, nargs="*", default=[3500, 4000, 45000, 50000],
                   help="more blocks to report, as start stop pairs")
    p.add_argument("--json", action="store_true")
    p.add_argument("--time-restore", action="store_true")
    p.add_argument("--at", type=int, default=None)
    p.add_argument("--then", type=int, default=0)
    args = p.parse_args()
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    (report if args.report else time_restore if args.time_restore else run)(args)


if __name__ == "__main__":
    main()
