"""The hadim experiment store: runs, dataset D, affordance events, interest maps, checkpoints.

Imports nothing from hadim_cli. Open one with ``Store.open(path_or_url)``; see docs/store.md.
``StoreReader.open(path)`` reads a run of a SQLite file without SQLAlchemy (hadim_store.reader).
"""

from __future__ import annotations

import importlib
from typing import Any

# Submodules are imported on first use: `import hadim_store.errors` must stay cheap (the CLI's
# `--help` imports it), while `hadim_store.api` pulls in SQLAlchemy.
_WHERE = {
    "DatasetArrays": "dataset", "Store": "api", "upgrade_store": "api",
    "StoreReader": "reader",
    "Upgrade": "schema",
    "CodecError": "errors", "RunLocked": "errors", "SchemaError": "errors",
    "StoreError": "errors", "UnknownRun": "errors",
    "SCHEMA_VERSION": "migrations",
    "AffordanceEvent": "records", "AffordanceStat": "records",
    "Checkpoint": "records", "EpisodeRecord": "records",
    "EpisodeWrite": "records", "Evaluation": "records",
    "InterestRegion": "records", "LockInfo": "records",
    "RunRecord": "records", "RunStatus": "records",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'hadim_store' has no attribute {name!r}")


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
    "StoreReader",
    "UnknownRun",
    "Upgrade",
    "upgrade_store",
]
