"""msgpack frames with numpy arrays, in the layout openpi's `openpi_client.msgpack_numpy` uses.

An array travels as a map {b"__ndarray__": True, b"data": raw bytes, b"dtype": dtype.str,
b"shape": shape}; a numpy scalar as {b"__npgeneric__": True, b"data": its Python value,
b"dtype": dtype.str}. Object, void and complex arrays are refused (they have no portable bytes).
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np

_REFUSED_KINDS = ("O", "V", "c")


def _encode(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)) and obj.dtype.kind in _REFUSED_KINDS:
        raise TypeError(f"cannot send a numpy value of dtype {obj.dtype} (object, void and complex are refused)")
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": np.ascontiguousarray(obj).tobytes(), b"dtype": obj.dtype.str, b"shape": obj.shape}
    if isinstance(obj, np.generic):
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    return obj


def _decode(obj: dict) -> Any:
    if b"__ndarray__" in obj:
        return np.ndarray(buffer=obj[b"data"], dtype=np.dtype(obj[b"dtype"]), shape=obj[b"shape"])
    if b"__npgeneric__" in obj:
        return np.dtype(obj[b"dtype"]).type(obj[b"data"])
    return obj


def pack(obj: Any) -> bytes:
    """One frame: `obj` (dicts, lists, numbers, strings, numpy arrays and scalars) as msgpack."""
    return msgpack.packb(obj, default=_encode, use_bin_type=True)


def unpack(frame: bytes) -> Any:
    """The object of one frame; arrays come back read-only, as views of the frame's bytes."""
    return msgpack.unpackb(frame, object_hook=_decode, raw=False)
