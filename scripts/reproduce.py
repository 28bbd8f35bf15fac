"""Reproduce the paper's experiments: configs × seeds, evaluation every 200 iterations.

    python scripts/reproduce.py --seeds 5 --iterations 4000 \
        --store results.sqlite --out docs/figures

Trains every (config, seed) as a run named `<config>-s<seed>` (skipping runs already finished,
resuming paused ones) with `--workers` processes, then draws the competence curves per task
(mean ± std per config, paper Fig. 2), the affordance timeline of the first default run (paper
Fig. 4) and writes `summary.json`: per config and checkpoint the mean/std of each task's score,
and per run its affordances at the end.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

CONFIGS = {"default": None, "random-only": "configs/random-only.toml",
           "goal-babbling-only": "configs/goal-babbling-only.toml"}


def train(store: str, config: str, seed: int, iterations: int, every: int) -> str:
    from hadim_cli import runs
    from store.errors import UnknownRun

    name = f"{config}-s{seed}"
    with runs.open_store(store) as st:
        try:
            record = st.get_run(name)
        except UnknownRun:
            record = None
    if record is not None and record.iterations >= iterations:
        return name
    if record is None:
        cmd = ["hadim", "train", "--iterations", str(iterations), "--seed", str(seed),
               "--name", name, "--eval-every", str(every), "--store", store]
        if CONFIGS[config]:
            cmd += ["--config", CONFIGS[config]]
    else:
        cmd = ["hadim", "resume", name, "--iterations", str(iterations), "--eval-every",
               str(every), "--store", store]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return name


def summarise(store: str, names: dict[str, list[str]], out: Path) -> dict:
    from hadim_cli import runs
    from hadim_cli.plots import comparison_figure, timeline_figure

    summary: dict = {"configs": {}, "runs": {}}
    with runs.open_store(store, create=False) as st:
        groups = {cfg: [st.evaluations(n) for n in ns] for cfg, ns in names.items()}
        comparison_figure(groups, out / "competence.png",
                          ("move-robot", "push-object", "push-with-tool"))
        first = names["default"][0]
        timeline_figure(st.events(first), st.get_run(first).iterations, out / "timeline.png")
        for cfg, evaluations in groups.items():
            table: dict = {}
            for evs in evaluations:
                for e in evs:
                    table.setdefault(e.task, {}).setdefault(e.iteration, []).append(e.score)
            summary["configs"][cfg] = {
                task: {str(it): {"mean": float(np.mean(v)), "std": float(np.std(v)),
                                 "n": len(v)} for it, v in sorted(by_it.items())}
                for task, by_it in table.items()}
        for ns in names.values():
            for n in ns:
                record = st.get_run(n)
                session = runs.restore_session(st, record)
                from hadim_cli.reports import affordance_rows

                summary["runs"][n] = {"iterations": record.iterations,
                                      "affordances": affordance_rows(session),
                                      "events": len(st.events(n))}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n")[0],
        epilog="Example: python scripts/reproduce.py --seeds 5 --iterations 4000 "
               "--store results.sqlite --out docs/figures  (15 runs; about 13 minutes on two "
               "cores, docs/performance.md). Then: python scripts/results_tables.py --store "
               "results.sqlite for the tables of docs/results.md.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--seeds", type=int, default=5,
                        help="seeds 0 .. N-1 of every config")
    parser.add_argument("--iterations", type=int, default=4000,
                        help="iterations per run (the paper's figures go to 4000)")
    parser.add_argument("--eval-every", type=int, default=200,
                        help="evaluate the tasks every N iterations (the curves' resolution)")
    parser.add_argument("--configs", nargs="*", default=list(CONFIGS), choices=list(CONFIGS),
                        help="which configs: default (sigma 0.7), random-only (0), "
                             "goal-babbling-only (1)")
    parser.add_argument("--workers", type=int, default=2,
                        help="runs trained at the same time, one process each")
    parser.add_argument("--store", default="results.sqlite",
                        help="store the runs go to (finished runs are kept, paused ones resumed)")
    parser.add_argument("--out", type=Path, default=Path("docs/figures"),
                        help="folder for competence.png, timeline.png and summary.json")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = [(c, s) for c in args.configs for s in range(args.seeds)]
    # Create the store once before the workers start.
    from hadim_cli import runs

    runs.open_store(args.store).close()
    with ThreadPoolExecutor(args.workers) as pool:
        done = list(pool.map(lambda j: train(args.store, j[0], j[1], args.iterations,
                                             args.eval_every), jobs))
    names: dict[str, list[str]] = {}
    for (cfg, _), name in zip(jobs, done, strict=True):
        names.setdefault(cfg, []).append(name)
    summary = summarise(args.store, names, args.out)
    for cfg, tasks in summary["configs"].items():
        last = {t: v[max(v, key=int)] for t, v in tasks.items()}
        print(cfg, {t: f"{x['mean']:.3f}±{x['std']:.3f}" for t, x in last.items()},
              file=sys.stderr)


if __name__ == "__main__":
    main()
