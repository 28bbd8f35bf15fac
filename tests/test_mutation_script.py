"""scripts/mutation.py (docs/testing.md, "Mutation testing"): a `--sample N` run tries N drawn
mutants of each module it names, even on a fresh `mutants/` where no mutant is written yet."""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

MODULE = textwrap.dedent('''
    def clip(x, low, high):
        if x < low:
            return low
        if x > high:
            return high
        return x


    def mean(values):
        return sum(values) / len(values)
''')


def _project(tmp_path: Path, monkeypatch):
    """A project of two small modules set up for mutmut, with a copy of the script."""
    package = tmp_path / "hadim_cli"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "small.py").write_text(MODULE)
    (package / "other.py").write_text(MODULE)
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "mutation.py", tmp_path / "scripts")
    (tmp_path / "pyproject.toml").write_text(textwrap.dedent('''
        [tool.mutmut]
        source_paths = ["hadim_cli"]
        only_mutate = ["hadim_cli/small.py", "hadim_cli/other.py"]
    '''))
    copy = tmp_path / "scripts" / "mutation.py"
    spec = importlib.util.spec_from_file_location("mutation_copy", copy)
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "mutation_copy", script)  # its dataclass needs its module
    spec.loader.exec_module(script)
    return script


def test_a_sample_on_a_fresh_mutants_dir_tries_that_many_drawn_mutants_of_each_module(
        tmp_path, monkeypatch):
    pytest.importorskip("mutmut")
    script = _project(tmp_path, monkeypatch)
    runs: list[list[str]] = []
    real_call = subprocess.call

    def mutmut_run(command, *args, **kwargs):
        if "mutmut" in command and "run" in command:  # record the names, run none
            runs.append(command[command.index("--max-children") + 2:])
            return 0
        return real_call(command, *args, **kwargs)

    monkeypatch.setattr(subprocess, "call", mutmut_run)
    assert script.main(["--sample", "3", "small.py", "other.py"]) == 0

    # Three mutants by name each, not a module's glob (all its mutants) for want of names.
    assert [len(names) for names in runs] == [3, 3], runs
    for names, module in zip(runs, ("small", "other"), strict=True):
        meta = json.loads((tmp_path / "mutants" / "hadim_cli" / f"{module}.py.meta").read_text())
        written = set(meta["exit_code_by_key"])
        assert len(written) > 3 and set(names) <= written, names
    # The same draw at every call: the names do not depend on the run.
    assert runs[0] == script.to_run("hadim_cli/small.py", 3)
