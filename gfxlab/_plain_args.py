"""Checks of plain Python arguments: flags, counts, seconds and paths.

Free of JAX (and of NumPy imports), so that `gfxlab.labs` and `gfxlab.grading`, which
must stay light, share them with the array-level checks of `gfxlab._checks`. A wrong
type raises `TypeError` and a bad value `ValueError`, each naming the argument.
"""

from __future__ import annotations

import math
import os
import sys


def shown(value) -> str:
    """A bounded repr of `value` for an error message."""
    return f"{value!r:.60}"


def flag(value, name: str, *, optional: bool = False) -> bool | None:
    """`value` as a bool if it is `True`/`False` (or a NumPy bool), else `TypeError`:
    `bool("no")` is True, so merely truthy values are refused. With `optional`, `None`
    passes too (a choice left to the function)."""
    if optional and value is None:
        return None
    numpy = sys.modules.get("numpy")  # a NumPy bool counts; NumPy is not imported for it
    if isinstance(value, bool) or (numpy is not None and isinstance(value, numpy.bool_)):
        return bool(value)
    choices = "True, False or None" if optional else "True or False"
    raise TypeError(f"`{name}` must be {choices}, got {shown(value)}")


def path_arg(value, name: str) -> str:
    """`value` as a string path: a `str` or an `os.PathLike`, else `TypeError`."""
    if not isinstance(value, str | os.PathLike) or isinstance(value, bytes):
        raise TypeError(f"`{name}` must be a path (str or os.PathLike), got {shown(value)}")
    path = os.fspath(value)
    if not isinstance(path, str):
        raise TypeError(f"`{name}` must be a str path, got {shown(path)}")
    return path


def positive_int(value, name: str) -> int:
    """`value` if it is an int above 0 (a bool is not), else `TypeError`/`ValueError`."""
    if not isinstance(value, int) or isinstance(value, bool):
        raise TypeError(f"`{name}` must be a positive int, got {shown(value)}")
    if value <= 0:
        raise ValueError(f"`{name}` must be a positive int, got {value}")
    return value


def positive_number(value, name: str, *, what: str = "number") -> float:
    """`value` as a float if it is a finite int or float above 0 (a bool is not); `what`
    names the quantity in the messages (e.g. "number of seconds")."""
    if not isinstance(value, int | float) or isinstance(value, bool):
        raise TypeError(f"`{name}` must be a positive {what}, got {shown(value)}")
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"`{name}` must be a positive, finite {what}, got {value!r}")
    return float(value)
