"""msgpack frames with numpy arrays, in the layout openpi's `openpi_client.msgpack_numpy` uses.

An array travels as a map {b"__ndarray__": True, b"data": raw bytes, b"dtype": dtype.str,
b"shape": shape}; a numpy scalar as {b"__npgeneric__": True, b"data": its Python value,
b"dtype": dtype.str}. Object, void and complex arrays are refused (they have no portable bytes).

`unpack` does not trust the peer: a frame it cannot decode safely raises `WireError` (one
sentence), never another exception and never a crash. It takes only bool, integer and float
dtypes, checks each array's shape against its bytes before building it, and caps an array's
bytes, the frame's bytes, the nesting depth and the entries of one map or list (the constants
below; keyword arguments of `unpack` override them).
"""

from __future__ import annotations

import math
from typing import Any

import msgpack
import numpy as np

_REFUSED_KINDS = ("O", "V", "c")

MAX_ARRAY_BYTES = 64 * 2**20  # one array's bytes (4 cameras at 448 x 448 x 3 uint8 are 2.4 MB in all)
MAX_FRAME_BYTES = 256 * 2**20  # one whole frame (also the websocket message limit of client and server)
MAX_DEPTH = 32  # maps and lists inside each other; an array's own map counts as one level
MAX_ENTRIES = 10_000  # entries of one map or list

_DECODED_KINDS = ("b", "i", "u", "f")  # bool, signed and unsigned integers, floats
_MAX_DIMS = 32  # numpy 1's limit (numpy 2 allows 64)
_MAX_DTYPE_CHARS = 16  # dtype.str is 2 to 4 characters ("|b1", "<f8", "<f16")
_LEAVES = (type(None), bool, int, float, str, bytes)


class WireError(ValueError):
    """A frame that cannot be decoded safely: not msgpack, truncated, too big, too deep, or
    holding an array whose dtype, shape or bytes cannot be trusted."""


def _encode(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)) and obj.dtype.kind in _REFUSED_KINDS:
        raise TypeError(f"cannot send a numpy value of dtype {obj.dtype} (object, void and complex are refused)")
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": np.ascontiguousarray(obj).tobytes(), b"dtype": obj.dtype.str, b"shape": obj.shape}
    if isinstance(obj, np.generic):
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    return obj


def pack(obj: Any) -> bytes:
    """One frame: `obj` (dicts, lists, numbers, strings, numpy arrays and scalars) as msgpack."""
    return msgpack.packb(obj, default=_encode, use_bin_type=True)


def _dtype(spec: Any, what: str) -> np.dtype:
    if not isinstance(spec, str) or not 0 < len(spec) <= _MAX_DTYPE_CHARS:
        raise WireError(f"{what} has a dtype that is not a short string ({type(spec).__name__})")
    try:
        dtype = np.dtype(spec)
    except Exception as exc:  # noqa: BLE001 - numpy raises TypeError, ValueError, SyntaxError...
        raise WireError(f"{what} has a dtype numpy cannot read ({spec!r})") from exc
    if dtype.kind not in _DECODED_KINDS or dtype.fields is not None or dtype.subdtype is not None:
        raise WireError(f"{what} has dtype {spec!r}; only bool, integer and float dtypes are accepted")
    return dtype


def _array(obj: dict, max_array_bytes: int) -> np.ndarray:
    dtype = _dtype(obj.get(b"dtype"), "an array")
    shape, data = obj.get(b"shape"), obj.get(b"data")
    if not isinstance(shape, list) or len(shape) > _MAX_DIMS or any(type(n) is not int or n < 0 for n in shape):
        raise WireError(f"an array's shape is not a list of at most {_MAX_DIMS} non-negative integers ({shape!r:.80})")
    if not isinstance(data, bytes):
        raise WireError(f"an array's data is not bytes ({type(data).__name__})")
    # Python ints: no overflow. Zero dimensions are left out of the bound, so that an empty array
    # with a huge other dimension (which numpy cannot make) is over the cap too
    bound = math.prod(n for n in shape if n) * dtype.itemsize
    if bound > max_array_bytes:
        raise WireError(f"an array of shape {tuple(shape)} and dtype {dtype.str} is over the cap of {max_array_bytes} bytes")
    size = math.prod(shape) * dtype.itemsize
    if len(data) != size:
        raise WireError(f"an array of shape {tuple(shape)} and dtype {dtype.str} needs {size} bytes but its data has {len(data)}")
    try:
        return np.frombuffer(data, dtype=dtype).reshape(shape)
    except ValueError as exc:  # not expected after the checks above; never let it through
        raise WireError(f"an array of shape {tuple(shape)} and dtype {dtype.str} cannot be built ({exc})") from exc


def _scalar(obj: dict) -> np.generic:
    dtype = _dtype(obj.get(b"dtype"), "a numpy scalar")
    value = obj.get(b"data")
    if type(value) not in (bool, int, float):
        raise WireError(f"a numpy scalar's value is not a number ({type(value).__name__})")
    try:
        return dtype.type(value)
    except Exception as exc:  # noqa: BLE001 - e.g. OverflowError: 300 as uint8
        raise WireError(f"a numpy scalar's value {value!r} does not fit dtype {dtype.str}") from exc


def _restore(obj: Any, depth: int, limits: tuple[int, int]) -> Any:
    """`obj` as decoded by msgpack, its array and scalar maps turned into numpy values."""
    if isinstance(obj, _LEAVES):
        return obj
    max_depth, max_array_bytes = limits
    if depth > max_depth:
        raise WireError(f"the frame nests maps and lists more than {max_depth} deep")
    if isinstance(obj, dict):
        if b"__ndarray__" in obj:
            return _array(obj, max_array_bytes)
        if b"__npgeneric__" in obj:
            return _scalar(obj)
        return {key: _restore(value, depth + 1, limits) for key, value in obj.items()}
    if isinstance(obj, list):
        return [_restore(value, depth + 1, limits) for value in obj]
    raise WireError(f"the frame holds a msgpack extension value ({type(obj).__name__}), which is not accepted")


def unpack(frame: bytes, *, max_array_bytes: int = MAX_ARRAY_BYTES, max_frame_bytes: int = MAX_FRAME_BYTES,
           max_depth: int = MAX_DEPTH, max_entries: int = MAX_ENTRIES) -> Any:
    """The object of one frame; arrays come back read-only, as views of the frame's bytes.
    Raises WireError (one sentence) for any frame it cannot decode safely."""
    if not isinstance(frame, (bytes, bytearray, memoryview)):
        raise WireError(f"a frame must be bytes, got {type(frame).__name__}")
    size = memoryview(frame).nbytes
    if size > max_frame_bytes:
        raise WireError(f"the frame has {size} bytes, over the cap of {max_frame_bytes}")
    try:
        # strict_map_key (the default): map keys are strings or bytes; msgpack's own stack stops
        # nesting at 1024 before _restore applies max_depth
        obj = msgpack.unpackb(frame, raw=False, max_array_len=max_entries, max_map_len=max_entries)
    except msgpack.StackError as exc:
        raise WireError(f"the frame nests maps and lists more than {max_depth} deep") from exc
    except msgpack.FormatError as exc:
        raise WireError("the frame is not valid msgpack (it holds a byte that starts no msgpack value)") from exc
    except msgpack.ExtraData as exc:
        raise WireError("the frame has bytes after its msgpack value") from exc
    except UnicodeDecodeError as exc:
        raise WireError("the frame holds a string that is not UTF-8") from exc
    except Exception as exc:  # noqa: BLE001 - msgpack raises ValueError, FormatError, TypeError...
        reason = str(exc).replace("Unpack failed: ", "") or type(exc).__name__
        if "exceeds max_array_len" in reason or "exceeds max_map_len" in reason:
            raise WireError(f"the frame has a map or list of more than {max_entries} entries") from exc
        if "incomplete input" in reason:
            raise WireError("the frame is truncated (it ends inside a msgpack value)") from exc
        raise WireError(f"the frame is not valid msgpack ({reason})") from exc
    try:
        return _restore(obj, 1, (max_depth, max_array_bytes))
    except RecursionError as exc:  # only with a max_depth near Python's recursion limit
        raise WireError(f"the frame nests maps and lists too deep to decode (max_depth={max_depth})") from exc
