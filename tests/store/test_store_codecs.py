"""No pickle: crafted blobs are refused, never executed."""

from __future__ import annotations

import io
import pickle
import re
import zlib
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import text

from hadim_store import CodecError, codecs

STORE_DIR = Path(__file__).resolve().parents[2] / "store"


class _Boom:
    def __reduce__(self):
        return (exec, ("raise SystemExit('pickle payload ran')",))


def _pickled_npy() -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.array([_Boom()], dtype=object), allow_pickle=True)
    return buffer.getvalue()


@pytest.mark.parametrize(
    "array",
    [
        np.arange(6, dtype=np.int64).reshape(2, 3),
        np.asfortranarray(np.random.default_rng(0).normal(size=(3, 4))),
        np.array(3.5),
        np.zeros((0, 5), dtype=np.float32),
        np.array([True, False]),
        np.arange(4, dtype=">u4"),
        np.zeros(2, dtype=[("x", "<f8"), ("n", "<i4")]),
    ],
)
@pytest.mark.parametrize("compress", [False, True])
def test_array_round_trip(array, compress):
    blob = codecs.encode_array(array, compress=compress)
    back = codecs.decode_array(blob, codecs.NPY_ZLIB if compress else codecs.NPY)
    assert back.dtype == array.dtype and back.shape == array.shape
    assert np.array_equal(back, array) and back.tobytes() == array.tobytes()
    assert not back.flags.writeable


def test_object_arrays_refused_on_write():
    with pytest.raises(CodecError, match="object"):
        codecs.encode_array(np.array([{"a": 1}], dtype=object))


def test_pickled_object_array_refused_without_running(store, make_episode):
    blob = _pickled_npy()
    with pytest.raises(CodecError):
        codecs.decode_array(blob)
    with pytest.raises(CodecError):
        codecs.decode_array(zlib.compress(blob), codecs.NPY_ZLIB)
    # The same blob planted in a stored checkpoint, as a crafted store file would have it.
    store.create_run(config={}, seed=1)
    store.write_episode("run-1", make_episode(0, 0))
    with store.engine.begin() as conn:
        conn.execute(text("UPDATE checkpoint_items SET kind = 'npy', data = :blob"), {"blob": blob})
    with pytest.raises(CodecError):
        store.checkpoint("run-1")


@pytest.mark.parametrize(
    "blob",
    [
        b"",
        b"garbage bytes, not an array",
        b"\x93NUMPY\x01\x00garbage",
        pickle.dumps(np.arange(3)),
        codecs.encode_array(np.arange(100))[:-7],
    ],
)
def test_garbage_refused(blob):
    with pytest.raises(CodecError):
        codecs.decode_array(blob)


@pytest.mark.parametrize("codec", [codecs.NPY, codecs.NPY_ZLIB])
@pytest.mark.parametrize("change", ["cut 1", "cut 4", "cut 5", "cut half", "2 bytes more"])
def test_a_blob_cut_short_or_padded_is_refused(codec, change):
    """Bytes lost at the end of a blob (a copy cut short) or added to it: a deflated array
    whose checksum is cut off still inflates whole, so the stream's end is checked too."""
    blob = codecs.encode_array(np.arange(100.0), compress=codec == codecs.NPY_ZLIB)
    if change == "2 bytes more":
        blob += b"\x00\x01"
    else:
        blob = blob[:-(len(blob) // 2 if change == "cut half" else int(change.split()[1]))]
    with pytest.raises(CodecError):
        codecs.decode_array(blob, codec)


@pytest.mark.parametrize("dtype", ["<f8", ">f4", "<i8", "|u1", "|b1", "<U3", "<c16", "<M8[s]",
                                   [("x", "<f8"), ("n", "<i4")]])
@pytest.mark.parametrize("shape", [(), (0,), (7,), (3, 0), (2, 3), (2, 3, 4)])
@pytest.mark.parametrize("fortran", [False, True])
def test_arrays_read_back_as_numpy_reads_them(dtype, shape, fortran):
    """The reader of np.save's usual header agrees with numpy's own, whatever the array."""
    array = np.asarray(np.random.default_rng(3).integers(0, 9, size=shape)).astype(dtype)
    if fortran:
        array = np.asfortranarray(array)
    blob = codecs.encode_array(array)
    back = codecs.decode_array(blob)
    expected = np.lib.format.read_array(io.BytesIO(blob), allow_pickle=False)
    assert back.dtype == expected.dtype and back.shape == expected.shape
    assert back.tobytes(order="A") == expected.tobytes(order="A")
    assert back.flags.f_contiguous == expected.flags.f_contiguous
    assert not back.flags.writeable


def test_bad_zlib_and_unknown_codec_refused():
    with pytest.raises(CodecError, match="zlib"):
        codecs.decode_array(b"not deflated", codecs.NPY_ZLIB)
    with pytest.raises(CodecError, match="unknown array codec"):
        codecs.decode_array(codecs.encode_array(np.arange(3)), "pickle")


def test_json_strict():
    assert codecs.decode_json(codecs.encode_json({"b": np.float32(0.5), "a": np.int64(2)})) == {
        "a": 2,
        "b": 0.5,
    }
    for bad in [{"x": float("nan")}, {"x": float("inf")}, {"x": np.zeros(2)}, {"x": {1, 2}}]:
        with pytest.raises(CodecError):
            codecs.encode_json(bad)
    with pytest.raises(CodecError):
        codecs.decode_json('{"x": NaN}')
    with pytest.raises(CodecError):
        codecs.decode_json("{not json")


def test_no_pickle_in_store_package():
    forbidden = re.compile(r"^\s*(import|from)\s+(c?pickle|dill|cloudpickle|joblib)\b|torch\.load")
    offenders = [
        f"{path.name}:{number}"
        for path in sorted(STORE_DIR.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if forbidden.search(line) or "allow_pickle=True" in line
    ]
    assert offenders == []


def test_store_imports_nothing_from_hadim_cli():
    pattern = re.compile(r"^\s*(import|from)\s+hadim_cli\b", re.MULTILINE)
    assert [p.name for p in STORE_DIR.rglob("*.py") if pattern.search(p.read_text())] == []
