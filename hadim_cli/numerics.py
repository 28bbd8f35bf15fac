"""One set of floating-point kernels on every x86-64 machine, so that a run resumes bit-exactly
wherever its store is opened.

numpy, its OpenBLAS and torch's MKL each pick their kernels for the CPU they load on, and the
AVX-512 kernels round differently from the AVX2 ones: the inverse model's least squares of one
planned action came out 1 ulp apart on an AVX-512 machine and on an AVX2 one, and the run went
its own way from there (a store written on one resumed on the other, or the same seed trained
on both, gave different D by iteration 12). A shared PostgreSQL store is opened from several
machines, and a fixture store is replayed by the tests on whatever machine runs them.

`pin_kernels` (run when `hadim_cli` is imported, before numpy is) asks each library for its
AVX2 kernels — those of x86-64-v3, which every machine here has — through the environment
variables they read when they load. A variable the user set is left as it is, and
`HADIM_NATIVE_KERNELS=1` leaves all of them unset (the machine's own kernels: faster where the
AVX-512 ones are, reproducible only on machines of the same kind). Imported after numpy, it
cannot act: `kernels()` then reports what numpy loaded.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

NATIVE_ENV = "HADIM_NATIVE_KERNELS"
"""Set to 1: keep each library's own choice of kernels for this CPU."""

AVX512 = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512F", "AVX512CD", "AVX512_KNL",
          "AVX512_KNM", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL", "AVX512_FP16")
"""numpy's names of the AVX-512 dispatch targets (numpy 2 groups, then numpy 1's); numpy ignores
a name it does not know or a feature the CPU lacks."""

PINNED = {
    "NPY_DISABLE_CPU_FEATURES": ",".join(AVX512),
    "OPENBLAS_CORETYPE": "Haswell",   # OpenBLAS's AVX2 kernels (Zen maps to them as well)
    "MKL_CBWR": "AVX2",               # MKL's conditional numerical reproducibility
    "ATEN_CPU_CAPABILITY": "avx2",    # torch's own vectorised kernels
}


def _has_avx2(cpuinfo: Path = Path("/proc/cpuinfo")) -> bool:
    """Whether the CPU runs AVX2 kernels (x86-64 Linux; False where it cannot be told)."""
    try:
        with cpuinfo.open() as f:
            for line in f:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    return {"avx2", "fma"} <= flags
    except OSError:
        pass
    return False


UNPINNED = ("numpy was imported before hadim_cli: it runs this machine's own kernels, and a "
            "run here may differ in its last bits, then in its course, from the same run of the "
            "`hadim` command (import hadim_cli first, or set HADIM_NATIVE_KERNELS=1 to keep "
            "the machine's kernels and silence this)")
"""The warning of a process that loaded numpy unpinned: a script that imported numpy first
scored a stored learner 0.9585 on the tool task where `hadim eval` (and its training) gave
0.9629 — one planned action 1.7e-15 apart, amplified by the contacts."""


def pin_kernels() -> None:
    """Set the variables of `PINNED` the user has not set, when the CPU has AVX2 and numpy is
    not loaded yet (and `NATIVE_ENV` does not ask for the machine's own kernels). With numpy
    loaded already and the variables not set, warn (`UNPINNED`): nothing can pin it now."""
    if os.environ.get(NATIVE_ENV, "") not in ("", "0") or not _has_avx2():
        return
    if "numpy" in sys.modules:
        if any(key not in os.environ for key in PINNED):
            warnings.warn(UNPINNED, RuntimeWarning, stacklevel=3)
        return
    for key, value in PINNED.items():
        os.environ.setdefault(key, value)


def kernels() -> dict[str, object]:
    """What this process runs on: the pinning variables and the dispatch targets numpy uses."""
    import numpy as np

    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1
        from numpy.core import _multiarray_umath as umath
    return {"env": {k: os.environ.get(k) for k in (*PINNED, NATIVE_ENV)},
            "numpy": np.__version__,
            "numpy_targets": [t for t in umath.__cpu_dispatch__ if umath.__cpu_features__.get(t)]}
