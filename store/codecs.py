"""Safe encodings of what the store keeps: arrays as ``.npy`` bytes, structures as JSON.

No pickle, ever: arrays are written and read with ``allow_pickle=False`` and object dtypes
are refused both ways, so a store file received from someone else cannot run code. Every
failure is a :class:`~hadim_store.errors.CodecError`.
"""

from __future__ import annotations

import io
import json
import math
import re
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from hadim_store.errors import CodecError

NPY = "npy"
NPY_ZLIB = "npy+zlib"
ARRAY_CODECS = (NPY, NPY_ZLIB)
_NPY_MAGIC = b"\x93NUMPY"
# The header np.save writes for a plain dtype (format 1.0, after the magic, the version and the
# header's length): read without `ast.literal_eval`, which is most of the cost of reading a
# checkpoint's many small arrays. Any other header goes to numpy's own reader.
_NPY_HEADER = re.compile(rb"\{'descr': '([<>|=]?[A-Za-z]\d*)', 'fortran_order': (False|True), "
                         rb"'shape': \(((?:\d+, ?)*\d*)\), \} *\n")
# A blob may not inflate beyond this: a crafted zlib stream must not exhaust memory.
MAX_ARRAY_BYTES = 1 << 32
_ZLIB_LEVEL = 1


def encode_array(array: np.ndarray, *, compress: bool = False) -> bytes:
    """``array`` as ``.npy`` bytes (zlib-deflated if ``compress``); object dtypes refused."""
    array = np.asanyarray(array)
    if type(array) is not np.ndarray:
        raise CodecError(f"cannot store a {type(array).__name__}: only plain numpy arrays")
    if array.dtype.hasobject:
        raise CodecError(f"cannot store an array of dtype {array.dtype}: object arrays need pickle")
    buffer = io.BytesIO()
    try:
        np.save(buffer, array, allow_pickle=False)
    except (ValueError, TypeError) as exc:
        raise CodecError(f"cannot encode array of dtype {array.dtype}: {exc}") from exc
    data = buffer.getvalue()
    return zlib.compress(data, _ZLIB_LEVEL) if compress else data


def decode_array(blob: bytes, codec: str = NPY) -> np.ndarray:
    """The array stored in ``blob``; read-only. Refuses anything but a plain ``.npy`` array."""
    if codec not in ARRAY_CODECS:
        raise CodecError(f"unknown array codec {codec!r} (expected one of {ARRAY_CODECS})")
    data = bytes(blob)
    if codec == NPY_ZLIB:
        data = _inflate(data)
    if not data.startswith(_NPY_MAGIC):
        raise CodecError("refused blob: not .npy data")
    try:
        array = _plain_npy(data)
        if array is None:
            stream = io.BytesIO(data)
            array = np.lib.format.read_array(stream, allow_pickle=False)
            if stream.tell() != len(data):
                raise ValueError(f"{len(data) - stream.tell()} bytes after the array's data")
    except Exception as exc:  # any parse failure of untrusted bytes is a refusal
        raise CodecError(f"refused .npy blob: {exc}") from exc
    if array.dtype.hasobject:  # read_array already refuses these; belt and braces
        raise CodecError("refused .npy blob: object dtype")
    array.flags.writeable = False
    return array


def _plain_npy(data: bytes) -> np.ndarray | None:
    """The array of a `.npy` blob with np.save's usual header (format 1.0, a plain dtype);
    None for any other header. Its data must fill the rest of the blob exactly."""
    if data[6:8] != b"\x01\x00" or len(data) < 10:
        return None
    start = 10 + int.from_bytes(data[8:10], "little")
    header = _NPY_HEADER.fullmatch(data, 10, start)
    if header is None:
        return None
    dtype = np.dtype(header[1].decode("ascii"))
    if dtype.hasobject:
        return None  # numpy's reader refuses it with its own reason
    shape = tuple(int(n) for n in header[3].split(b",") if n.strip())
    count = math.prod(shape)
    if len(data) - start != count * dtype.itemsize:
        raise ValueError(f"expected {count * dtype.itemsize} bytes of array data, "
                         f"got {len(data) - start}")
    array = np.frombuffer(data, dtype, count, start)
    if header[2] == b"True":  # as numpy reads it: the reversed shape, transposed
        return array.reshape(shape[::-1]).transpose()
    return array.reshape(shape)


def _inflate(data: bytes) -> bytes:
    inflater = zlib.decompressobj()
    try:
        out = inflater.decompress(data, MAX_ARRAY_BYTES)
    except zlib.error as exc:
        raise CodecError(f"refused blob: bad zlib data ({exc})") from exc
    if inflater.unconsumed_tail:
        raise CodecError(f"refused blob: inflates beyond {MAX_ARRAY_BYTES} bytes")
    # A stream cut short may still inflate whole (only its checksum lost): its end must be
    # there, and nothing after it.
    if not inflater.eof or inflater.unused_data:
        raise CodecError("refused blob: bad zlib data (the stream is cut short or followed "
                         "by other bytes)")
    return out


def _to_builtin(value: Any) -> Any:
    """JSON fallback for numpy scalars and read-only mappings; arrays belong in .npy items."""
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, (set, frozenset)):
        raise TypeError("sets have no order: pass a sorted list")
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def encode_json(value: Any) -> str:
    """``value`` as compact, key-sorted JSON. Non-finite floats are refused.

    Tuples come back as lists; dict keys must be strings.
    """
    try:
        return json.dumps(
            value, allow_nan=False, sort_keys=True, separators=(",", ":"), default=_to_builtin
        )
    except (TypeError, ValueError, RecursionError) as exc:
        raise CodecError(f"cannot encode as JSON: {exc}") from exc


def _refuse_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name}")


def decode_json(text: str | bytes | None) -> Any:
    """The value in ``text`` (None for a NULL column); NaN/Infinity refused."""
    if text is None:
        return None
    try:
        return json.loads(text, parse_constant=_refuse_constant)
    except (ValueError, TypeError, RecursionError) as exc:
        raise CodecError(f"refused JSON: {exc}") from exc


def finite_or_none(value: float | None, what: str) -> float | None:
    """``value`` as a float, refusing NaN and infinities (None passes)."""
    if value is None:
        return None
    result = float(value)
    if not math.isfinite(result):
        raise CodecError(f"{what} must be finite, got {result}")
    return result
