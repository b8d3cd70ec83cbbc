"""What public tests use, importable in a student notebook and in the sandbox.

`check_array` gives clear feedback on a returned value's type, shape and dtype;
`run_tests(namespace, names)` runs a public-test cell's tests on the notebook's own
functions (each test receives the functions named by its parameters), prints PASS/FAIL
with the reason and never raises, so "Run All" goes through an unsolved notebook. It only
needs numpy.
"""

from __future__ import annotations

import inspect

import numpy as np

__all__ = ["Feedback", "check_array", "run_tests"]

RESULTS: dict[str, list] = {}


class Feedback(AssertionError):
    """A failure with a message about the value's type, shape or dtype."""


def check_array(value, *, shape=None, dtype=None, kind=None, name="the result"):
    """Check a student's returned value is an array of the expected shape and dtype.

    **Arguments:**

    - `value`: what the student's function returned.
    - `shape`: expected shape (tuple; `None` entries match any size).
    - `dtype`: expected exact dtype (e.g. `np.float64`).
    - `kind`: expected dtype kind: `"f"` float, `"i"` integer (signed or unsigned), `"b"` bool.
    - `name`: how the feedback names the value.

    **Returns:** `value` as a numpy array. Raises `Feedback` (an `AssertionError`) with a
    clear message otherwise.
    """
    arraylike = isinstance(value, (np.ndarray, list, tuple, np.generic, int, float))
    if not arraylike and not hasattr(value, "__array__"):
        raise Feedback(f"{name} should be an array, got {type(value).__name__}")
    try:
        array = np.asarray(value)
    except (ValueError, TypeError):
        raise Feedback(f"{name} should be an array; it is ragged or mixed") from None
    if array.dtype == object:
        raise Feedback(f"{name} should be a numeric array; it is ragged or mixed")
    if shape is not None:
        ok = array.ndim == len(shape) and all(
            s is None or s == n for s, n in zip(shape, array.shape, strict=False)
        )
        if not ok:
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise Feedback(f"{name} should have shape {want}, got shape {array.shape}")
    if kind is not None:
        kinds = {"f": "f", "i": "iu", "b": "b"}[kind]
        if array.dtype.kind not in kinds:
            words = {"f": "a floating-point", "i": "an integer", "b": "a boolean"}[kind]
            raise Feedback(f"{name} should have {words} dtype, got {array.dtype}")
    if dtype is not None and array.dtype != np.dtype(dtype):
        raise Feedback(f"{name} should have dtype {np.dtype(dtype)}, got {array.dtype}")
    return array


def _message(exc: BaseException) -> str:
    if isinstance(exc, AssertionError):
        text = str(exc).strip() or "assertion failed"
    else:
        text = f"{type(exc).__name__}: {exc}"
    return text[:1000]


def run_tests(namespace: dict, names, *, question: str = "", echo: bool = True) -> list:
    """Run the tests `names` of `namespace` on the functions of `namespace`.

    **Returns:** `[(test name, passed, message), ...]`; prints one line per test (with
    `echo`). Never raises: a failing or crashing test is reported as FAIL.
    """
    results = []
    for name in names:
        test = namespace.get(name)
        try:
            params = list(inspect.signature(test).parameters)
            missing = [p for p in params if not callable(namespace.get(p))]
            if missing:
                raise AssertionError(f"`{missing[0]}` is not defined as a function")
            test(*[namespace[p] for p in params])
        except Exception as exc:
            results.append((name, False, _message(exc)))
        else:
            results.append((name, True, ""))
    if question:
        RESULTS[question] = results
    if echo:
        for name, passed, message in results:
            print(f"{'PASS' if passed else 'FAIL'} {name}" + (f": {message}" if message else ""))
    return results
