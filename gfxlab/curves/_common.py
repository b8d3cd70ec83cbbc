"""Helpers shared by the curve modules: parameter shapes, value checks, safe ratios."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._checks import as_float, common_float, is_traced, value_error_if

#: Largest degree of a Bezier curve or patch (`bernstein`, `elevate_degree`): the basis
#: table grows with the degree, so larger values are refused before allocating.
MAX_DEGREE = 1024
#: Largest degree of a B-spline (its span conversion is unrolled over the degree).
MAX_BSPLINE_DEGREE = 32
#: Largest number of B-spline control points made by `uniform_knots`/`clamped_knots`.
MAX_CONTROL_POINTS = 10_000_000
#: Largest grid resolution of `patch_mesh`/`teapot` (cells per patch side).
MAX_RESOLUTION = 512


def _flat_parameters(u: jax.Array) -> tuple[jax.Array, tuple[int, ...]]:
    """`u` as a flat `(N,)` array and its original shape (to restore the output)."""
    return u.reshape(-1), tuple(u.shape)


def _unflatten(points: jax.Array, axis_size_shape: tuple[int, ...], axis: int) -> jax.Array:
    """Replace the flat parameter axis `axis` of `points` by the shape `axis_size_shape`."""
    axis = axis % points.ndim
    return points.reshape(points.shape[:axis] + axis_size_shape + points.shape[axis + 1 :])


def _floats(*arrays, names: tuple[str, ...]) -> list:
    """`common_float(*arrays, names=names)`, with a fast path (no dispatch) for the usual
    case of concrete JAX arrays of one floating dtype, possibly with Python numbers
    (which take that dtype, as JAX's weak types do): keeps the eager fixed overhead of a
    public call small. Python numbers come back as NumPy scalars, which the jitted
    kernels take directly."""
    dtypes = {
        a.dtype for a in arrays if isinstance(a, jax.Array) and not isinstance(a, jax.core.Tracer)
    }
    fast = len(dtypes) == 1 and jnp.issubdtype(next(iter(dtypes)), jnp.floating)
    fast = fast and all(
        isinstance(a, jax.Array)
        and not isinstance(a, jax.core.Tracer)
        or (type(a) is float and math.isfinite(a))
        or (type(a) is int and abs(a) < 2**53)
        for a in arrays
    )
    if not fast:
        return common_float(*arrays, names=names)
    dtype = next(iter(dtypes))
    return [a if isinstance(a, jax.Array) else np.asarray(a, dtype) for a in arrays]


def _require(x, message: str, bad, *context):
    """`x`, after raising `ValueError(message)` where `bad(x, *context)` holds.

    Concrete values are checked in NumPy (no JAX dispatch or compilation per shape);
    traced ones go through `value_error_if` (`equinox.error_if` under `jit`).
    """
    if is_traced((x, context)):
        return value_error_if(x, bad(x, *context), message)
    if np.asarray(bad(np.asarray(x), *(np.asarray(c) for c in context))).any():
        raise ValueError(message)
    return x


def _require_between(x, lo, hi, message: str):
    """`x`, after raising `ValueError(message)` unless every entry lies in `[lo, hi]`
    (NaN does not). Concrete values take two NumPy reductions (no temporaries, fast on
    10^6 parameters); traced ones go through `value_error_if`."""
    if is_traced((x, lo, hi)):
        if x.size == 0:
            return x
        # One scalar predicate from two fused reductions (NaN fails both comparisons):
        # much cheaper under `jit` than a per-entry mask on 10^6 parameters.
        return value_error_if(x, ~((jnp.min(x) >= lo) & (jnp.max(x) <= hi)), message)
    values = np.asarray(x)
    if values.size and not (values.min() >= lo and values.max() <= hi):
        raise ValueError(message)
    return x


def _check_unit_interval(u: jax.Array, name: str = "u") -> jax.Array:
    return _require_between(
        u, 0.0, 1.0, f"`{name}` must lie in [0, 1], the parameter range of a Bezier curve"
    )


def _control_points(
    control_points: Float[ArrayLike, "*batch n d"], name: str = "control_points"
) -> jax.Array:
    cp = as_float(control_points, name)
    if cp.ndim < 2 or cp.shape[-2] < 1:
        raise ValueError(
            f"`{name}` must have shape (..., n+1, d): at least one point of dimension d, "
            f"got shape {tuple(cp.shape)}"
        )
    return _require(cp, f"`{name}` must be finite (no NaN or inf)", _not_finite)


def _not_finite(x):
    return ~np.isfinite(x) if isinstance(x, np.ndarray) else ~jnp.isfinite(x)


def _safe_ratio(numerator: jax.Array, denominator: jax.Array) -> jax.Array:
    """`numerator / denominator`, with the B-spline convention `x / 0 = 0` (double
    `where`, so gradients stay finite)."""
    nonzero = denominator != 0
    return jnp.where(nonzero, numerator / jnp.where(nonzero, denominator, 1), 0)


def _float_dtype(dtype):
    return jnp.result_type(float) if dtype is None else jnp.dtype(dtype)
