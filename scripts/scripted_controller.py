"""The scripted upper bound of every task file: `hadim_cli.evaluation.scripted` (see there).

    python scripts/scripted_controller.py                       # every task of configs/tasks/
    python scripts/scripted_controller.py --task push-with-tool [--json]
"""

from __future__ import annotations

import sys

from hadim_cli.evaluation.scripted import main, run_task  # noqa: F401  (run_task: tests)

if __name__ == "__main__":
    sys.exit(main())
