"""A throw-away local Ray cluster the sweep tests share: one head, every sweep joins it with
`--address`.

Starting Ray is most of a small sweep's cost (10–15 s on a loaded 2-core machine, against 2–5 s
to join a running head), so the sweeps of one test module join one head instead of each
starting its own. The head is a child process that runs `ray.init` and waits on its stdin:
closing stdin shuts Ray down (and so does the test process dying, which closes the pipe). Its
Ray files live in a short temporary directory of their own (Unix socket paths are limited to
107 bytes), so it never touches another Ray instance on the machine.

Ray ≥ 2.5x enables token authentication on a local cluster; drivers joining it would need the
token, so the head and its drivers run with `RAY_AUTH_MODE=disabled` (`ENV`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

ENV = {"RAY_AUTH_MODE": "disabled"}
START_TIMEOUT_S = 120

_HEAD = """
import logging, sys, ray
context = ray.init(num_cpus=int(sys.argv[1]), include_dashboard=False, _temp_dir=sys.argv[2],
                   logging_level=logging.WARNING, log_to_driver=False)
print(context.address_info["gcs_address"], flush=True)
sys.stdin.read()
ray.shutdown()
"""


@dataclass(frozen=True)
class RayCluster:
    address: str
    process: subprocess.Popen
    root: Path

    def stop(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        try:
            self.process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        shutil.rmtree(self.root, ignore_errors=True)


def start(num_cpus: int = 2) -> RayCluster:
    """A head of `num_cpus` cores; its address is what `hadim sweep --address` takes."""
    root = Path(tempfile.mkdtemp(prefix="hadim-ray-"))
    with open(root / "head.err", "w") as err:
        process = subprocess.Popen(
            [sys.executable, "-c", _HEAD, str(num_cpus), str(root)], env={**os.environ, **ENV},
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, text=True)
    line: list[str] = []
    reader = threading.Thread(target=lambda: line.append(process.stdout.readline()),
                              daemon=True)
    reader.start()
    reader.join(START_TIMEOUT_S)
    address = line[0].strip() if line else ""
    if not address:
        cluster = RayCluster("", process, root)
        error = (root / "head.err").read_text(errors="replace")[-2000:]
        cluster.stop()
        raise RuntimeError(f"the Ray head did not start in {START_TIMEOUT_S} s: {error}")
    return RayCluster(address, process, root)
