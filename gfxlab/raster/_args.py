"""Argument helpers for the raster and image packages: checks in Python, no array work.

Public functions check shapes, dtypes and static values here and leave every array
operation to one jitted inner function. Value checks (NaN, ranges) run on the host
when the value is concrete, so an eager call raises `ValueError` at once, and through
`equinox.error_if` when it is traced (inside a user's `jax.jit`).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_traced, value_error_if


def array_arg(x, name: str, what: str = "an array of numbers"):
    """`x` as an array without computing anything: JAX arrays (and tracers) as they are,
    anything else through `np.asarray`. `None`, strings, non-numbers and complex values
    raise `TypeError` naming `name`."""
    if x is None:
        raise TypeError(f"`{name}` must be {what}, got None")
    if isinstance(x, jax.Array | np.ndarray):
        arr = x
    elif isinstance(x, str | bytes):
        raise TypeError(f"`{name}` must be {what}, got {type(x).__name__}")
    else:
        try:
            arr = np.asarray(x)
        except (TypeError, ValueError) as err:
            raise TypeError(f"`{name}` must be {what}, got {type(x).__name__}") from err
    dtype = arr.dtype
    if not (np.issubdtype(dtype, np.number) or dtype == np.bool_) or jnp.issubdtype(
        dtype, jnp.complexfloating
    ):
        if jnp.issubdtype(dtype, jnp.complexfloating):
            raise TypeError(f"`{name}` must be real, got dtype {dtype}")
        raise TypeError(f"`{name}` must be {what}, got dtype {dtype}")
    return arr


def float_dtype(x) -> jnp.dtype:
    """The float dtype a computation on `x` runs in: `x`'s own, or JAX's default float."""
    dtype = jnp.result_type(x)
    return dtype if jnp.issubdtype(dtype, jnp.floating) else jnp.result_type(float)


def host_or_traced_check(x, bad_fn, message: str):
    """Raise `ValueError(message)` where `bad_fn(values)` holds: on the host (NumPy) when
    `x` is concrete, through `equinox.error_if` when traced. Returns `x`, which must be
    used so that the traced check is not dead code."""
    if is_traced(x):
        return value_error_if(x, bad_fn(jnp.asarray(x)), message)
    if np.any(bad_fn(np.asarray(x))):
        raise ValueError(message)
    return x


def finite_arg(x, name: str):
    """`x` after checking it holds no NaN or infinity (eagerly and under jit)."""
    return host_or_traced_check(
        x,
        lambda v: ~np.isfinite(v) if isinstance(v, np.ndarray) else ~jnp.isfinite(v),
        f"`{name}` must be finite (no NaN or inf)",
    )


def float_scalar(x, name: str, *, low=None, high=None, low_open=True, high_open=False):
    """A finite real scalar (Python number or 0-d array, possibly traced), with an
    optional range check: `low < x` (`low <= x` if not `low_open`) and `x <= high`
    (`x < high` if `high_open`)."""
    if x is None:
        raise TypeError(f"`{name}` must be a real number, got None")
    if isinstance(x, bool) or isinstance(x, str | bytes):
        raise TypeError(f"`{name}` must be a real number, got {x!r}")
    if isinstance(x, int | float):  # a Python number: check it without NumPy
        if not math.isfinite(x):
            raise ValueError(f"`{name}` must be finite (no NaN or inf)")
        v = float(x)
        if (low is not None and (v <= low if low_open else v < low)) or (
            high is not None and (v >= high if high_open else v > high)
        ):
            raise ValueError(
                f"`{name}` must be {_range_text(low, high, low_open, high_open)}, got {x!r}"
            )
        return x
    arr = array_arg(x, name, "a real number")
    if arr.dtype == np.bool_:  # as the Python bool above, also when traced
        raise TypeError(f"`{name}` must be a real number, got a boolean array")
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar, got shape {tuple(arr.shape)}")
    checked = finite_arg(x if is_traced(x) else np.asarray(x, dtype=float), name)
    checked = range_check(checked, name, low=low, high=high, low_open=low_open, high_open=high_open)
    return checked if is_traced(x) else x


def range_check(x, name: str, *, low=None, high=None, low_open=True, high_open=False):
    """`x` after checking every entry lies in the given range (eagerly and under jit)."""
    if low is None and high is None:
        return x

    def bad(v):
        out = False
        if low is not None:
            out = out | ((v <= low) if low_open else (v < low))
        if high is not None:
            out = out | ((v >= high) if high_open else (v > high))
        return out

    what = _range_text(low, high, low_open, high_open)
    shown = "" if is_traced(x) else f", got {np.asarray(x).tolist()}"
    return host_or_traced_check(x, bad, f"`{name}` must be {what}{shown}")


def _range_text(low, high, low_open, high_open) -> str:
    """`in (0, 1]`, `> 0`, `<= 1`, ... for error messages."""
    if low is not None and high is not None:
        return f"in {'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}"
    if low is not None:
        return f"{'>' if low_open else '>='} {low}"
    return f"{'<' if high_open else '<='} {high}"
