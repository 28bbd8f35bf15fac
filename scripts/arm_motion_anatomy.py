"""What the arm's learned motion costs its tasks, and what a frame of the shoulder would buy
(`hadim_cli/evaluation/motion_anatomy.py`).

    python scripts/arm_motion_anatomy.py --store arm.sqlite [--run run-1] [--json]
"""

from __future__ import annotations

import sys

from hadim_cli.evaluation.motion_anatomy import main

if __name__ == "__main__":
    sys.exit(main())
