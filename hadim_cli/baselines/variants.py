"""Named variants of a baseline's protocol (issue 46): the paper's, and the one a practitioner
would fix it to. A variant is a set of parameters written into the run's config (so a stored
run says what it is), not a flag threaded through the agents.
"""

from __future__ import annotations

import enum

from hadim_cli.baselines.agents import BaselineConfig


class Variant(enum.StrEnum):
    PAPER = "paper"
    """The paper's protocol as the 50 000-iteration grids ran it (docs/baselines.md)."""


def apply_variant(cfg: BaselineConfig, variant: Variant) -> BaselineConfig:
    """`cfg` with the variant's parameters."""
    if variant is Variant.PAPER:
        return cfg
    raise ValueError(f"unknown variant {variant!r}")  # pragma: no cover

