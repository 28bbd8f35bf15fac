"""Checkpoint state as JSON and arrays, never pickle: torch state dicts, optimiser states and
the global random generators that stable-baselines3 draws from.

`split` turns a nested structure (dicts with any keys, lists, tensors, arrays, numbers) into a
JSON tree plus named arrays; `join` rebuilds it, tensors as tensors. Dicts are written as lists
of [key, value] pairs so integer keys (an optimiser's parameter ids) come back as integers.
"""

from __future__ import annotations

from typing import Any

import numpy as np

_ARRAY, _TENSOR, _DICT, _TUPLE = "__array__", "__tensor__", "__dict__", "__tuple__"


def split(obj: Any, prefix: str, arrays: dict[str, np.ndarray]) -> Any:
    """`obj` as JSON, its tensors and arrays moved into `arrays` under keys from `prefix`."""
    import torch

    if isinstance(obj, torch.Tensor):
        arrays[prefix] = obj.detach().cpu().numpy().copy()
        return {_TENSOR: prefix}
    if isinstance(obj, np.ndarray):
        arrays[prefix] = obj.copy()
        return {_ARRAY: prefix}
    if isinstance(obj, dict):
        return {_DICT: [[k, split(v, f"{prefix}.{k}", arrays)] for k, v in obj.items()]}
    if isinstance(obj, tuple):
        return {_TUPLE: [split(v, f"{prefix}.{i}", arrays) for i, v in enumerate(obj)]}
    if isinstance(obj, list):
        return [split(v, f"{prefix}.{i}", arrays) for i, v in enumerate(obj)]
    if isinstance(obj, np.generic):
        return obj.item()
    if obj is None or isinstance(obj, bool | int | float | str):
        return obj
    raise TypeError(f"cannot checkpoint a {type(obj).__name__} at {prefix}")


def join(tree: Any, arrays: dict[str, np.ndarray]) -> Any:
    """The structure `split` wrote, tensors rebuilt from their arrays."""
    import torch

    if isinstance(tree, list):
        return [join(v, arrays) for v in tree]
    if isinstance(tree, dict):
        if _TENSOR in tree:
            return torch.from_numpy(np.array(arrays[tree[_TENSOR]]))
        if _ARRAY in tree:
            return np.array(arrays[tree[_ARRAY]])
        if _TUPLE in tree:
            return tuple(join(v, arrays) for v in tree[_TUPLE])
        return {k: join(v, arrays) for k, v in tree[_DICT]}
    return tree


def global_rngs(arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """The states of numpy's and torch's global generators (SB3 draws from them: replay
    sampling, ε-exploration, A2C's action sampling). SB3 seeds Python's `random` too but
    never draws from it while learning (a chunk leaves it unchanged), and other libraries of
    the process do, so it is not part of a run's state."""
    import torch

    name, keys, pos, has_gauss, cached = np.random.get_state()
    arrays["rng.numpy_keys"] = np.asarray(keys, dtype=np.uint32)
    arrays["rng.torch"] = torch.get_rng_state().numpy().copy()
    return {"numpy": [name, int(pos), int(has_gauss), float(cached)]}


def set_global_rngs(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    import torch

    name, pos, has_gauss, cached = meta["numpy"]
    np.random.set_state((name, np.array(arrays["rng.numpy_keys"], dtype=np.uint32), pos,
                         has_gauss, cached))
    torch.set_rng_state(torch.from_numpy(np.array(arrays["rng.torch"], dtype=np.uint8)))
