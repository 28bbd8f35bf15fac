"""The hadim experiment store: runs, dataset D, affordance events, interest maps, checkpoints.

Imports nothing from hadim_cli. Open one with ``Store.open(path_or_url)``; see docs/store.md.
"""

from __future__ import annotations

import importlib
from typing import Any

# Submodules are imported on first use: `import store.errors` must stay cheap (the CLI's
# `--help` imports it), while `store.api` pulls in SQLAlchemy.
_WHERE = {
    "DatasetArrays": "store.api", "Store": "store.api", "upgrade_store": "store.api",
    "Upgrade": "store.schema",
    "CodecError": "store.errors", "RunLocked": "store.errors", "SchemaError": "store.errors",
    "StoreError": "store.errors", "UnknownRun": "store.errors",
    "SCHEMA_VERSION": "store.migrations",
    "AffordanceEvent": "store.records", "AffordanceStat": "store.records",
    "Checkpoint": "store.records", "EpisodeRecord": "store.records",
    "EpisodeWrite": "store.records", "Evaluation": "store.records",
    "InterestRegion": "store.records", "LockInfo": "store.records",
    "RunRecord": "store.records", "RunStatus": "store.records",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'store' has no attribute {name!r}")


__all__ = [
    "SCHEMA_VERSION",
    "AffordanceEvent",
    "AffordanceStat",
    "Checkpoint",
    "CodecError",
    "DatasetArrays",
    "EpisodeRecord",
    "EpisodeWrite",
    "Evaluation",
    "InterestRegion",
    "LockInfo",
    "RunLocked",
    "RunRecord",
    "RunStatus",
    "SchemaError",
    "Store",
    "StoreError",
    "UnknownRun",
    "Upgrade",
    "upgrade_store",
]
