"""Mutation testing of the algorithm's modules with mutmut 3, one module at a time.

    python scripts/mutation.py evaluation/metric.py learner/competence.py   # run, then summarise
    python scripts/mutation.py --report                                     # summarise only
    python scripts/mutation.py --show learner/competence.py                 # each survivor's diff
    python scripts/mutation.py --sample 200 learner/models.py               # 200 drawn mutants

mutmut (configured in pyproject.toml, `[tool.mutmut]`) copies the sources into `mutants/`,
writes every mutant of the configured modules there, records once which of the selected tests
reach which function, and runs, for each mutant, only those tests. This script restricts a run
to the modules named, with one worker and at low priority (`nice`), and resumes: a module
already run (its source unchanged since) runs again only its mutants not yet killed — the
not-yet-checked ones of an interrupted run, and the survivors, which a new test may now kill.
A module whose source changed runs whole again. `--fresh-stats` forgets which tests reach which
function (needed when an existing test starts reaching a function it did not; new tests are
found by mutmut itself). A `--sample` run first writes the mutants of modules never written or
changed since (mutmut's generation step, none run), so that it draws from their names.

The summary counts, per module, mutants killed / survived / timed out / not reached by any
selected test, and the share killed out of those that are not listed as equivalent in
docs/equivalent-mutants.md (a mutant that cannot change behaviour, with the reason).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MUTANTS = ROOT / "mutants"
EQUIVALENTS = ROOT / "docs" / "equivalent-mutants.md"
NICE = 15

# mutmut's exit codes (mutmut/stats.py); anything else is "suspicious".
STATUS = {1: "killed", 3: "killed", 0: "survived", 5: "no tests", 33: "no tests",
          34: "skipped", 36: "timeout", 24: "timeout", -24: "timeout", 152: "timeout",
          255: "timeout", None: "not checked", -9: "segfault", -11: "segfault"}
COLUMNS = ("killed", "survived", "timeout", "no tests", "not checked", "other")


def configured() -> tuple[list[str], list[str]]:
    """The modules pyproject.toml lets mutmut mutate (globs) and those it must not."""
    import tomllib

    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mutmut"]
    return conf["only_mutate"], conf.get("do_not_mutate", [])


def module_path(name: str) -> str:
    """`learner/models.py`, `hadim_cli/learner/models.py` or `hadim_cli.learner.models`."""
    name = name.strip()
    if not name.endswith(".py"):
        name = name.replace(".", "/") + ".py"
    if not name.startswith("hadim_cli/"):
        name = "hadim_cli/" + name
    return name


def mutable_modules() -> list[str]:
    """Every configured module, in the order of pyproject.toml's list."""
    from fnmatch import fnmatch

    only, never = configured()
    found = []
    for pattern in only:
        for path in sorted(ROOT.glob(pattern)):
            rel = path.relative_to(ROOT).as_posix()
            if (path.suffix == ".py" and path.name != "__init__.py" and rel not in found
                    and not any(fnmatch(rel, p) for p in never)):
                found.append(rel)
    return found


def dotted(path: str) -> str:
    return path.removesuffix(".py").replace("/", ".")


def results(path: str) -> dict[str, int | None] | None:
    """mutmut's record of the module's mutants (name → exit code), None before a first run."""
    meta = MUTANTS / (path + ".meta")
    if not meta.exists():
        return None
    return json.loads(meta.read_text())["exit_code_by_key"]


def stale(path: str) -> bool:
    """True when the module changed since its mutants were written (or never was mutated)."""
    meta = MUTANTS / (path + ".meta")
    return not meta.exists() or (ROOT / path).stat().st_mtime > meta.stat().st_mtime


def equivalents() -> dict[str, str]:
    """Mutant name → why it cannot change behaviour (docs/equivalent-mutants.md's table)."""
    if not EQUIVALENTS.exists():
        return {}
    rows = re.findall(r"^\| `([\w.]+__mutmut_\d+)` \| (.*?) \|$", EQUIVALENTS.read_text(),
                      flags=re.M)
    return dict(rows)


@dataclass
class Summary:
    module: str
    counts: Counter
    equivalent: int

    @property
    def score(self) -> float | None:
        relevant = sum(self.counts.values()) - self.equivalent - self.counts["not checked"]
        return None if relevant <= 0 else self.counts["killed"] / relevant


def summarise(path: str) -> Summary | None:
    codes = results(path)
    if codes is None:
        return None
    same = equivalents()
    counts: Counter = Counter()
    n_equivalent = 0
    for name, code in codes.items():
        status = STATUS.get(code, "other")
        if name in same and status != "killed":
            n_equivalent += 1
            status = "equivalent"
        counts[status if status in COLUMNS or status == "equivalent" else "other"] += 1
    return Summary(path, counts, n_equivalent)


def print_table(paths: list[str]) -> None:
    head = ["module", *COLUMNS, "equivalent", "killed %"]
    print(" | ".join(head))
    print(" | ".join("---" for _ in head))
    for path in paths:
        s = summarise(path)
        if s is None:
            print(f"{path} | not run yet")
            continue
        score = "—" if s.score is None else f"{100 * s.score:.0f}"
        cells = [path, *(str(s.counts[c]) for c in COLUMNS), str(s.equivalent), score]
        print(" | ".join(cells))


def to_run(path: str, sample: int | None = None) -> list[str]:
    """The mutant names (or the module's glob) a run of `path` must try: with `sample`, at
    most that many of the mutants never checked (a fixed draw, the same at every call) and
    every mutant checked but not killed."""
    codes = results(path)
    if codes is None or (stale(path) and sample is None):
        return [dotted(path) + ".*"]
    same = equivalents()
    todo = sorted(n for n, c in codes.items() if STATUS.get(c) != "killed" and n not in same)
    if sample is None:
        return todo
    unchecked = sorted(n for n in todo if codes[n] is None)
    rng = random.Random(f"{path}:{sample}")
    drawn = set(rng.sample(unchecked, min(sample, len(unchecked))))
    return [n for n in todo if codes[n] is not None or n in drawn]


# mutmut's generation step alone, as `mutmut run` begins (mutmut/__main__.py, `_run`): the
# sources copied into mutants/ and every configured module's mutants written, none run.
GENERATE = """
import os, sys
import mutmut.__main__ as m
m.set_mutant_under_test("mutant_generation")
os.makedirs("mutants", exist_ok=True)
m.copy_src_dir()
m.copy_also_copy_files()
m.setup_source_paths()
m.store_lines_covered_by_tests()
print(m.create_mutants(int(sys.argv[1])))
"""


def generate(workers: int) -> int:
    """Write the mutants of every configured module (those written already, of unchanged
    sources, are kept with their results), so that a draw has names to draw from."""
    print("writing the mutants (none run)", flush=True)
    done = subprocess.run(["nice", "-n", str(NICE), sys.executable, "-c", GENERATE,
                           str(workers)], cwd=ROOT)
    return done.returncode


def run(paths: list[str], workers: int, sample: int | None = None) -> int:
    if sample is not None and any(results(p) is None or stale(p) for p in paths):
        code = generate(workers)
        if code:
            print(f"mutmut's generation stopped with exit code {code}", file=sys.stderr)
            return code
    for path in paths:
        names = to_run(path, sample)
        if not names:
            print(f"{path}: every mutant killed or equivalent; nothing to run")
            continue
        print(f"{path}: {len(names)} mutant(s) or pattern(s) to run", flush=True)
        command = ["nice", "-n", str(NICE), sys.executable, "-m", "mutmut", "run",
                   "--max-children", str(workers), *names]
        # One thread each for torch and the BLAS libraries: a worker does not fight the others.
        env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "OPENBLAS_NUM_THREADS": "1"}
        code = subprocess.call(command, cwd=ROOT, env=env)
        if code not in (0,):
            print(f"{path}: mutmut stopped with exit code {code}", file=sys.stderr)
            return code
    return 0


def show(paths: list[str]) -> None:
    same = equivalents()
    for path in paths:
        for name, code in sorted((results(path) or {}).items()):
            if STATUS.get(code) in ("survived", "timeout", "no tests") and name not in same:
                subprocess.call([sys.executable, "-m", "mutmut", "show", name], cwd=ROOT)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("modules", nargs="*", help="modules to mutate (default with --report: "
                        "every configured module)")
    parser.add_argument("--report", action="store_true", help="summarise the last results only")
    parser.add_argument("--show", action="store_true", help="print each survivor's diff")
    parser.add_argument("--workers", type=int, default=1, help="mutmut's --max-children")
    parser.add_argument("--sample", type=int, metavar="N",
                        help="try at most N of the module's mutants not yet checked (a fixed "
                        "draw; for a first estimate of a large module)")
    parser.add_argument("--fresh-stats", action="store_true",
                        help="forget which tests reach which function (recorded again)")
    args = parser.parse_args(argv)
    known = mutable_modules()
    paths = [module_path(m) for m in args.modules] or known
    unknown = [p for p in paths if p not in known]
    if unknown:
        print(f"not configured for mutation (pyproject.toml [tool.mutmut]): {unknown}",
              file=sys.stderr)
        return 2
    if args.show:
        show(paths)
        return 0
    if not args.report:
        if not args.modules:
            print("name the modules to run (one at a time keeps a run short): "
                  f"{', '.join(known)}", file=sys.stderr)
            return 2
        if args.fresh_stats:
            (MUTANTS / "mutmut-stats.json").unlink(missing_ok=True)
        code = run(paths, args.workers, args.sample)
        if code:
            return code
    print_table(paths)
    return 0


if __name__ == "__main__":
    sys.exit(main())
