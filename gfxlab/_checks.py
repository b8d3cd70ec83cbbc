"""Argument checks shared by every module.

Shape and static-value problems raise `ValueError`/`TypeError` at trace time. Value
problems (a degenerate window, a non-unit direction) raise `ValueError` at once when
the value is concrete and go through `equinox.error_if` when it is traced, so the
same call gives a clear error with and without `jax.jit`.
"""

from __future__ import annotations

import operator
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np


def is_traced(x) -> bool:
    """True when `x` (or any leaf of it) is a JAX tracer, i.e. its value is unknown."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(x))


def as_float(x, name: str = "x") -> jax.Array:
    """`x` as a floating JAX array, keeping a floating input dtype.

    Integer and boolean inputs become the default float dtype (float32, or float64
    under `jax_enable_x64`).
    """
    if x is None:
        raise TypeError(f"`{name}` must be an array of numbers, got None")
    try:
        arr = jnp.asarray(x)
    except TypeError as err:
        raise TypeError(f"`{name}` must be array-like of numbers, got {type(x).__name__}") from err
    if jnp.issubdtype(arr.dtype, jnp.complexfloating):
        raise TypeError(f"`{name}` must be real, got dtype {arr.dtype}")
    if not jnp.issubdtype(arr.dtype, jnp.floating):
        arr = arr.astype(jnp.result_type(float))
    return arr


def common_float(*arrays, names: Sequence[str]) -> list[jax.Array]:
    """Several arrays as floats promoted to one common dtype."""
    arrays = [as_float(a, n) for a, n in zip(arrays, names, strict=True)]
    dtype = jnp.result_type(*arrays)
    return [a.astype(dtype) for a in arrays]


def check_last_dim(x: jax.Array, name: str, sizes: Sequence[int], what: str = "") -> int:
    """Check that `x.shape[-1]` is one of `sizes`; return it."""
    if x.ndim == 0 or x.shape[-1] not in sizes:
        allowed = " or ".join(str(s) for s in sizes)
        hint = f" ({what})" if what else ""
        raise ValueError(
            f"`{name}` must have shape (..., {allowed}){hint}, got shape {tuple(x.shape)}"
        )
    return x.shape[-1]


def check_shape(x: jax.Array, name: str, shape: tuple) -> None:
    """Check that `x.shape` matches `shape`, where `None` entries match any size and a
    leading `...` matches any batch dimensions."""
    shape = tuple(shape)
    batch = len(shape) > 0 and shape[0] is Ellipsis
    core = shape[1:] if batch else shape
    actual = tuple(x.shape)
    ok = len(actual) >= len(core) if batch else len(actual) == len(core)
    if ok:
        tail = actual[len(actual) - len(core) :] if core else ()
        ok = all(c is None or c == a for c, a in zip(core, tail, strict=True))
    if not ok:
        pretty = ", ".join("..." if s is Ellipsis else "n" if s is None else str(s) for s in shape)
        raise ValueError(f"`{name}` must have shape ({pretty}), got shape {actual}")


def static_int(
    value, name: str, *, minimum: int | None = None, maximum: int | None = None
) -> int:
    """A static (Python) integer argument, such as a radius, a degree or an image size.

    `maximum` bounds sizes that allocate memory, so a huge value is refused before any
    allocation rather than hanging or exhausting memory.
    """
    if isinstance(value, jax.core.Tracer):
        raise TypeError(
            f"`{name}` sets an array size, so it must be a static Python int, not a traced "
            "value; mark it static (e.g. `jax.jit(f, static_argnames=...)`)"
        )
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        if isinstance(value, float | np.floating) and float(value).is_integer():
            value = int(value)
        elif (
            isinstance(value, np.ndarray | jax.Array)
            and value.shape == ()
            and jnp.issubdtype(value.dtype, jnp.integer)
        ):
            value = int(value)
        else:
            raise TypeError(f"`{name}` must be an int, got {value!r}")
    value = operator.index(value)
    if minimum is not None and value < minimum:
        raise ValueError(f"`{name}` must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"`{name}` must be <= {maximum} (a documented size limit), got {value}")
    return value


def static_shape(shape, name: str = "shape") -> tuple[int, int]:
    """An image shape `(H, W)` (extra trailing entries such as channels are ignored)."""
    if not isinstance(shape, Sequence) or len(shape) < 2:
        raise ValueError(f"`{name}` must be an image shape (H, W), got {shape!r}")
    return static_int(shape[0], f"{name}[0]", minimum=1), static_int(
        shape[1], f"{name}[1]", minimum=1
    )


def value_error_if(x, bad, message: str):
    """Raise `ValueError(message)` if `bad` holds anywhere.

    Concrete values raise at once; traced values go through `equinox.error_if`, which
    raises at run time under `jit`. Returns `x` (which must be used, so that the check
    is not dead code under `jit`).
    """
    if not is_traced(bad) and not is_traced(x):
        if bool(np.any(np.asarray(bad))):
            raise ValueError(message)
        return x
    return eqx.error_if(x, bad, message)


def check_finite(x, name: str):
    """`x` unchanged, after checking that it holds no NaN or infinity (eagerly and under jit)."""
    return value_error_if(x, ~jnp.isfinite(x), f"`{name}` must be finite (no NaN or inf)")


def finite_float(x, name: str = "x") -> jax.Array:
    """`as_float(x, name)` that also rejects NaN and infinite values."""
    return check_finite(as_float(x, name), name)


def check_rect(rect, name: str) -> jax.Array:
    """A rectangle `(xmin, ymin, xmax, ymax)` with positive width and height."""
    rect = as_float(rect, name)
    check_shape(rect, name, (4,))
    bad = (rect[2] <= rect[0]) | (rect[3] <= rect[1])
    return value_error_if(
        rect,
        bad,
        f"`{name}` must be (xmin, ymin, xmax, ymax) with xmax > xmin and ymax > ymin "
        "(a rectangle with positive width and height)",
    )


def safe_norm(x: jax.Array, axis: int = -1, keepdims: bool = False) -> jax.Array:
    """Euclidean norm whose gradient is zero, not NaN, at the zero vector."""
    sq = jnp.sum(x * x, axis=axis, keepdims=keepdims)
    positive = sq > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, sq, 1.0)), 0.0)


def safe_divide(numerator: jax.Array, denominator: jax.Array) -> jax.Array:
    """`numerator / denominator` with `|denominator|` clamped to at least machine epsilon.

    Keeps values and gradients finite (large, not infinite or NaN) where the
    denominator vanishes, e.g. the perspective divide of a point on the camera plane.
    """
    eps = jnp.finfo(jnp.result_type(denominator, float)).eps
    small = jnp.abs(denominator) < eps
    sign = jnp.where(denominator < 0, -1.0, 1.0).astype(jnp.result_type(denominator, float))
    return numerator / jnp.where(small, sign * eps, denominator)


def safe_normalize(x: jax.Array, axis: int = -1) -> jax.Array:
    """`x / |x|` along `axis`; the zero vector stays zero with finite gradients."""
    length = safe_norm(x, axis=axis, keepdims=True)
    return x / jnp.where(length > 0, length, 1.0)
