"""Plain-data wire format between the grader and the student process.

Only plain data crosses the process boundary: `None`, `bool`, `int`, `float`, `str`,
`list`, `tuple`, `dict` and numpy arrays of numeric or bool dtype. Messages are JSON
(never pickle) framed by a 4-byte big-endian length. The grader decodes replies with
`decode`, which rebuilds only those types, so a reply can never contain an object with
its own `__eq__` or any other behaviour.

This file is also sent verbatim as the first part of the student worker's source, so it
imports only the standard library and numpy.
"""

import base64
import json
import struct

import numpy as np

MAX_MESSAGE_BYTES = 64 * 2**20
MAX_DEPTH = 32
MAX_ITEMS = 2_000_000
# Keys other than `str` have a hash the sender can choose (ints, floats, tuples all
# colliding): a few thousand at most, so rebuilding a dict can never take quadratic time.
# (`str` hashes are randomized per process.)
MAX_HASHED_KEYS = 2_000
ALLOWED_DTYPES = frozenset(
    ["bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64"]
    + ["float16", "float32", "float64", "complex64", "complex128"]
)


class WireError(ValueError):
    """A value that is not plain data, or a malformed message."""


def encode(value, _depth=0):
    """Plain data -> JSON-able structure with tagged tuples, dicts and arrays.

    Exact types only: a subclass of `list` or `float` (which could carry its own
    `__eq__`) is refused, not silently converted.
    """
    if _depth > MAX_DEPTH:
        raise WireError(f"nested deeper than {MAX_DEPTH} levels")
    kind = type(value)
    if value is None or kind in (bool, str):
        return value
    if kind is int:
        return value
    if kind is float:
        return {"f": repr(value)}
    if kind is list:
        return [encode(v, _depth + 1) for v in value]
    if kind is tuple:
        return {"t": [encode(v, _depth + 1) for v in value]}
    if kind is dict:
        return {"d": [[encode(k, _depth + 1), encode(v, _depth + 1)] for k, v in value.items()]}
    if kind is np.ndarray or isinstance(value, np.generic):
        array = np.asarray(value)
        if array.dtype.name not in ALLOWED_DTYPES:
            raise WireError(f"arrays of dtype {array.dtype} cannot be returned")
        data = np.ascontiguousarray(array).astype(array.dtype.newbyteorder("<"), copy=False)
        return {
            "a": array.dtype.name,
            "s": list(array.shape),
            "b": base64.b64encode(data.tobytes()).decode("ascii"),
            "g": isinstance(value, np.generic),
        }
    raise WireError(
        f"values of type {kind.__module__}.{kind.__qualname__} cannot be returned; "
        "use numbers, strings, lists, tuples, dicts or numpy arrays"
    )


class _Budget:
    def __init__(self, deadline=None):
        self.items = 0
        self.keys = 0
        self.deadline = deadline

    def take(self, n):
        self.items += n
        if self.items > MAX_ITEMS:
            raise WireError(f"more than {MAX_ITEMS} values")
        if self.deadline is not None and self.items % 4096 < n + 1:
            import time

            if time.monotonic() > self.deadline:
                raise WireError("the reply took too long to read")

    def key(self, key):
        if type(key) is not str:
            self.keys += 1
            if self.keys > MAX_HASHED_KEYS:
                raise WireError(
                    f"more than {MAX_HASHED_KEYS} dict keys that are not strings; "
                    "return a list of pairs instead"
                )


def decode(obj, _depth=0, _budget=None, *, deadline=None):
    """Inverse of `encode`, strict: anything unexpected raises `WireError`.

    `deadline` (a `time.monotonic()` value) bounds the time spent decoding.
    """
    budget = _Budget(deadline) if _budget is None else _budget
    budget.take(1)
    if _depth > MAX_DEPTH:
        raise WireError(f"nested deeper than {MAX_DEPTH} levels")
    kind = type(obj)
    if obj is None or kind in (bool, str, int):
        return obj
    if kind is list:
        return [decode(v, _depth + 1, budget) for v in obj]
    if kind is not dict or len(obj) not in (1, 4):
        raise WireError(f"malformed value of JSON type {kind.__name__}")
    if len(obj) == 1:
        ((tag, body),) = obj.items()
        return _decode_tagged(tag, body, _depth, budget)
    return _decode_array(obj, budget)


def _decode_tagged(tag, body, depth, budget):
    """Decode a one-key `{tag: body}` value: a float, tuple or dict."""
    if tag == "f" and type(body) is str:
        try:
            return float(body)
        except ValueError:
            raise WireError("malformed float") from None
    if tag == "t" and type(body) is list:
        return tuple(decode(v, depth + 1, budget) for v in body)
    if tag == "d" and type(body) is list:
        return _decode_dict(body, depth, budget)
    raise WireError(f"unknown tag {tag!r}")


def _decode_dict(body, depth, budget):
    """Decode a dict's `[key, value]` pairs, checking keys and counting hashed ones."""
    out = {}
    for pair in body:
        if type(pair) is not list or len(pair) != 2:
            raise WireError("malformed dict entry")
        key = decode(pair[0], depth + 1, budget)
        if type(key) not in (str, int, float, bool, tuple) and key is not None:
            raise WireError("dict keys must be numbers, strings or tuples")
        budget.key(key)
        try:
            out[key] = decode(pair[1], depth + 1, budget)
        except TypeError:
            raise WireError("unhashable dict key") from None
    return out


def _decode_array(obj, budget):
    """Decode a four-key array value, checking dtype, shape, size and data length."""
    if set(obj) != {"a", "s", "b", "g"}:
        raise WireError("malformed array")
    dtype, shape, data, scalar = obj["a"], obj["s"], obj["b"], obj["g"]
    if type(dtype) is not str or dtype not in ALLOWED_DTYPES:
        raise WireError(f"arrays of dtype {dtype!r} are not accepted")
    if type(shape) is not list or not all(type(n) is int and 0 <= n for n in shape):
        raise WireError("malformed array shape")
    if len(shape) > MAX_DEPTH or type(data) is not str or type(scalar) is not bool:
        raise WireError("malformed array")
    size = 1
    for n in shape:
        size *= n
    budget.take(size)
    try:
        raw = base64.b64decode(data.encode("ascii"), validate=True)
    except ValueError:
        raise WireError("malformed array data") from None
    le = np.dtype(dtype).newbyteorder("<")
    if len(raw) != size * le.itemsize:
        raise WireError("array data does not match its shape and dtype")
    if any(n > 2**40 for n in shape):
        raise WireError("absurd array shape")
    try:
        array = np.frombuffer(raw, dtype=le).astype(np.dtype(dtype)).reshape(shape)
    except (ValueError, MemoryError):
        raise WireError("array data does not match its shape") from None
    if scalar:
        if shape:
            raise WireError("malformed scalar")
        return array[()]
    return array


def dumps(message):
    """Frame a JSON-able message (already encoded)."""
    body = json.dumps(message, separators=(",", ":"), allow_nan=False).encode("utf-8")
    if len(body) > MAX_MESSAGE_BYTES:
        raise WireError(f"message larger than {MAX_MESSAGE_BYTES} bytes")
    return struct.pack(">I", len(body)) + body


def loads(body):
    """Parse one frame body (bytes) as JSON; a JSON error becomes `WireError`.

    The number of values is bounded *before* parsing (`json.loads` builds every object
    first): each value after the first follows a `,` or opens a `[`/`{`, so their count
    bounds it, and a small frame of `[[],[],...]` cannot make the parser allocate
    gigabytes.
    """
    values = body.count(b",") + body.count(b"[") + body.count(b"{")
    if values > MAX_ITEMS:
        raise WireError(f"more than {MAX_ITEMS} values")
    try:
        return json.loads(body.decode("utf-8"))
    except (ValueError, RecursionError) as exc:
        raise WireError(f"malformed message: {exc.__class__.__name__}") from None
