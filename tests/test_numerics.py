"""The numeric kernels are pinned to AVX2 ones when hadim is imported before numpy, so a run is
the same on every machine (hadim_cli/numerics.py). The schema-1 and schema-2 fixture stores,
written on an AVX2 machine and resumed by the store tests, are the end-to-end check."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hadim_cli.numerics import NATIVE_ENV, PINNED, _has_avx2

REPORT = ("import hadim_cli, json; from hadim_cli.numerics import kernels; "
          "print(json.dumps(kernels()))")


def _kernels(**env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in PINNED and k != NATIVE_ENV}
    out = subprocess.run([sys.executable, "-c", REPORT], env={**clean, **env}, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


@pytest.mark.skipif(not _has_avx2(), reason="the pinned kernels are AVX2 ones")
def test_importing_hadim_first_pins_every_library_to_avx2_kernels():
    k = _kernels()
    assert k["env"] == {**PINNED, NATIVE_ENV: None}
    assert set(k["numpy_targets"]) <= {"X86_V2", "X86_V3", "AVX2", "FMA3", "AVX", "F16C"}


def test_a_variable_the_user_set_is_kept_and_native_sets_none():
    assert _kernels(OPENBLAS_CORETYPE="Sandybridge")["env"]["OPENBLAS_CORETYPE"] == "Sandybridge"
    native = _kernels(**{NATIVE_ENV: "1"})["env"]
    assert all(native[k] is None for k in PINNED)


def test_imported_after_numpy_it_sets_nothing():
    code = ("import numpy, hadim_cli, os; from hadim_cli.numerics import PINNED; "
            "print(sum(k in os.environ for k in PINNED))")
    clean = {k: v for k, v in os.environ.items() if k not in PINNED}
    out = subprocess.run([sys.executable, "-c", code], env=clean, check=True,
                         capture_output=True, text=True).stdout
    assert out.strip() == "0"


@pytest.mark.skipif(not _has_avx2(), reason="the pinned kernels are AVX2 ones")
def test_imported_after_numpy_it_warns_that_the_kernels_are_the_machines():
    """A scratch script that imported numpy first scored a stored learner 0.9585 on the tool
    task where `hadim eval` gave 0.9629. Imported after numpy (and no pinning set), hadim
    says so on stderr; imported first, set pinned by a parent process, or asked for the
    machine's kernels, it says nothing."""
    def stderr(code: str, **env: str) -> str:
        clean = {k: v for k, v in os.environ.items() if k not in PINNED and k != NATIVE_ENV}
        return subprocess.run([sys.executable, "-c", code], env={**clean, **env}, check=True,
                              capture_output=True, text=True).stderr

    assert "numpy was imported before hadim_cli" in stderr("import numpy, hadim_cli")
    assert stderr("import hadim_cli, numpy") == ""
    assert stderr("import numpy, hadim_cli", **PINNED) == ""
    assert stderr("import numpy, hadim_cli", **{NATIVE_ENV: "1"}) == ""
