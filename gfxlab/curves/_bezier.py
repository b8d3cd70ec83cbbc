"""Bezier curves: the Bernstein basis, de Casteljau, split, degree elevation, derivatives."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_shape, static_int
from ._common import (
    MAX_DEGREE,
    _check_unit_interval,
    _control_points,
    _flat_parameters,
    _floats,
    _unflatten,
)

# Up to this degree the Bernstein recursion is unrolled (XLA fuses it into one pass,
# `O(n^2)` operations in the program); above it, a `lax.scan` keeps the program small.
_UNROLL_DEGREE = 16


def _bernstein(n: int, u: jax.Array) -> jax.Array:
    """All degree-`n` Bernstein polynomials at `u`, `(*u.shape, n+1)`, unchecked: the one
    implementation of the basis in gfxlab (Bezier curves, patches, B-spline spans).

    Built by the recursion `B_{i,k} = (1-u) B_{i,k-1} + u B_{i-1,k-1}`: every term is
    non-negative, so it is stable for any degree, and the gradient is finite everywhere,
    including at `u = 0` and `u = 1`. Low degrees unroll the recursion on a list of
    columns; high degrees scan over a fixed `(..., n+1)` table whose entries `i > k` stay
    zero.
    """
    if n <= _UNROLL_DEGREE:
        v = 1 - u
        columns = [jnp.ones_like(u)]
        for _ in range(n):
            columns = (
                [v * columns[0]]
                + [v * b + u * a for a, b in zip(columns[:-1], columns[1:], strict=True)]
                + [u * columns[-1]]
            )
        return jnp.stack(columns, axis=-1)
    w = u[..., None]
    basis = jnp.zeros(u.shape + (n + 1,), u.dtype).at[..., 0].set(1)

    def raise_degree(b, _):
        shifted = jnp.concatenate([jnp.zeros_like(b[..., :1]), b[..., :-1]], axis=-1)
        return (1 - w) * b + w * shifted, None

    basis, _ = jax.lax.scan(raise_degree, basis, None, length=n)
    return basis


def bernstein(n: int, u: Float[ArrayLike, "*U"]) -> Float[Array, "*U n+1"]:
    """The Bernstein basis polynomials of degree `n`,
    `B_{i,n}(u) = C(n, i) u^i (1 - u)^(n - i)` for `i = 0..n`.

    This is gfxlab's one Bernstein basis (Bezier curves and patches, B-spline spans and
    easing curves use it). Differentiable in `u`, finite gradients at `u = 0` and `1`.

    **Arguments:**

    - `n`: the degree, a static int in `[0, MAX_DEGREE]`.
    - `u`: parameters in `[0, 1]`, any shape (usually `(N,)`).

    **Returns:** `(*u.shape, n+1)`; each row sums to one.

    **Raises:** `TypeError` for an `n` that is not a whole number (3 and 3.0 are
    accepted) or a `None`/non-numeric `u`; `ValueError` for `u` outside `[0, 1]` or NaN
    (eagerly, and through `equinox.error_if` under jit).
    """
    n = static_int(n, "n", minimum=0, maximum=MAX_DEGREE)
    u = _check_unit_interval(as_float(u, "u"))
    return _bernstein_kernel(n, u)


@functools.partial(jax.jit, static_argnums=0)
def _bernstein_kernel(n: int, u: jax.Array) -> jax.Array:
    return _bernstein(n, u)


@jax.jit
def _bezier_kernel(cp: jax.Array, u: jax.Array) -> jax.Array:
    flat, shape = _flat_parameters(u)
    n = cp.shape[-2] - 1
    basis = _bernstein(n, flat)
    if n <= _UNROLL_DEGREE:
        # Elementwise products summed: one fused pass (XLA's dot for a (N, n+1) x
        # (n+1, d) product is ~50x slower on CPU at N = 10^5).
        points = sum(basis[:, k, None] * cp[..., k, None, :] for k in range(n + 1))
    else:
        points = jnp.einsum("nk,...kd->...nd", basis, cp)
    return _unflatten(points, shape, -2)


def bezier(
    control_points: Float[ArrayLike, "*batch n+1 d"], u: Float[ArrayLike, " N"]
) -> Float[Array, "*batch N d"]:
    """A Bezier curve `P(u) = sum_i B_{i,n}(u) p_i` in the Bernstein form.

    **Arguments:**

    - `control_points`: `(..., n+1, d)`, any degree `n >= 0` and dimension `d`.
    - `u`: parameters in `[0, 1]`, `(N,)` (or any shape `U`; a scalar drops the axis).

    **Returns:** the curve points, `(..., N, d)` (or `(..., *U, d)`).

    **Raises:** `ValueError` for bad shapes or `u` outside `[0, 1]`.
    """
    cp = _control_points(control_points)
    cp, u = _floats(cp, u, names=("control_points", "u"))
    u = _check_unit_interval(u)
    return _bezier_kernel(cp, u)


def de_casteljau(
    control_points: Float[ArrayLike, "*batch n+1 d"], u: Float[ArrayLike, " N"]
) -> tuple[Float[Array, "*batch N _ d"], ...]:
    """de Casteljau's algorithm, step by step (a `lax.scan` over the levels).

    Level 0 is the control polygon; level `r` holds the `n + 1 - r` points
    `p_i^r = (1 - u) p_i^{r-1} + u p_{i+1}^{r-1}`; the single point of level `n` is the
    curve point `P(u)`, equal to `bezier(control_points, u)`.

    **Arguments:**

    - `control_points`: `(..., n+1, d)`.
    - `u`: parameters in `[0, 1]`, `(N,)`, or a scalar.

    **Returns:** a tuple of `n + 1` arrays; `levels[r]` has shape
    `(..., N, n+1-r, d)` (`(..., n+1-r, d)` for a scalar `u`), so
    `levels[-1][..., 0, :]` is the curve point.
    """
    cp = _control_points(control_points)
    cp, u = _floats(cp, u, names=("control_points", "u"))
    u = _check_unit_interval(u)
    return _de_casteljau_kernel(cp, u)


@jax.jit
def _de_casteljau_kernel(cp: jax.Array, u: jax.Array) -> tuple[jax.Array, ...]:
    flat, shape = _flat_parameters(u)
    n = cp.shape[-2] - 1
    polygon = jnp.broadcast_to(
        cp[..., None, :, :], cp.shape[:-2] + (flat.shape[0],) + cp.shape[-2:]
    )
    w = flat[:, None, None]

    def one_level(points, _):
        # Blend each point with its successor; the last slot becomes padding, which
        # later levels never read.
        blended = (1 - w) * points + w * jnp.roll(points, -1, axis=-2)
        return blended, blended

    _, stacked = jax.lax.scan(one_level, polygon, None, length=n)
    levels = [polygon] + [stacked[r - 1][..., : n + 1 - r, :] for r in range(1, n + 1)]
    return tuple(_unflatten(level, shape, -3) for level in levels)


def split(
    control_points: Float[ArrayLike, "*batch n+1 d"], t: Float[ArrayLike, ""] = 0.5
) -> tuple[Float[Array, "*batch n+1 d"], Float[Array, "*batch n+1 d"]]:
    """Split a Bezier curve at `t` into two of the same degree (by de Casteljau).

    The left piece traces `P(u)` for `u` in `[0, t]`, the right one `u` in `[t, 1]`, each
    reparameterised to `[0, 1]`.

    **Arguments:**

    - `control_points`: `(..., n+1, d)`.
    - `t`: the split parameter, a scalar in `[0, 1]`.

    **Returns:** `(left, right)`, each `(..., n+1, d)`.
    """
    t = as_float(t, "t")
    check_shape(t, "t", ())
    cp = _control_points(control_points)
    cp, t = _floats(cp, t, names=("control_points", "t"))
    return _split_kernel(cp, _check_unit_interval(t, "t"))


@jax.jit
def _split_kernel(cp: jax.Array, t: jax.Array) -> tuple[jax.Array, jax.Array]:
    levels = _de_casteljau_kernel(cp, t)
    n = len(levels) - 1
    left = jnp.stack([level[..., 0, :] for level in levels], axis=-2)
    right = jnp.stack([levels[n - i][..., i, :] for i in range(n + 1)], axis=-2)
    return left, right


def elevate_degree(
    control_points: Float[ArrayLike, "*batch n+1 d"], *, times: int = 1
) -> Float[Array, "*batch n+1+times d"]:
    """The same curve with degree raised by `times`:
    `q_i = i/(n+1) p_{i-1} + (1 - i/(n+1)) p_i` for `i = 0..n+1`, repeated.

    **Arguments:**

    - `control_points`: `(..., n+1, d)`.
    - `times`: how many degrees to add, a static int in `[0, MAX_DEGREE - n]`.

    **Returns:** `(..., n+1+times, d)` control points.
    """
    cp = _control_points(control_points)
    n = cp.shape[-2] - 1
    times = static_int(times, "times", minimum=0, maximum=max(MAX_DEGREE - n, 0))
    return _elevate_kernel(cp, times)


def _elevation_matrix(n: int, times: int) -> np.ndarray:
    """The `(n+1+times, n+1)` matrix taking degree-`n` control points to the same curve's
    degree-`n+times` ones: the product of the one-step matrices (in float64 NumPy, once
    per static configuration)."""
    matrix = np.eye(n + 1)
    for k in range(n, n + times):
        a = np.arange(k + 2) / (k + 1)
        step = np.zeros((k + 2, k + 1))
        step[np.arange(1, k + 2), np.arange(k + 1)] = a[1:]  # p_{i-1}, weight i/(k+1)
        step[np.arange(k + 1), np.arange(k + 1)] = 1 - a[:-1]  # p_i, weight 1 - i/(k+1)
        matrix = step @ matrix
    return matrix


@functools.partial(jax.jit, static_argnums=1)
def _elevate_kernel(cp: jax.Array, times: int) -> jax.Array:
    matrix = jnp.asarray(_elevation_matrix(cp.shape[-2] - 1, times), cp.dtype)
    return jnp.einsum("ik,...kd->...id", matrix, cp)


def derivative(
    control_points: Float[ArrayLike, "*batch n+1 d"], *, order: int = 1
) -> Float[Array, "*batch n+1-order d"]:
    """Control points of the derivative curve (the hodograph):
    `P'(u) = sum_i B_{i,n-1}(u) n (p_{i+1} - p_i)`, applied `order` times.

    **Returns:** `(..., n+1-order, d)`; evaluate with `bezier` to get `P^(order)(u)`.
    """
    cp = _control_points(control_points)
    order = static_int(order, "order", minimum=1)
    if order >= cp.shape[-2]:
        raise ValueError(
            f"`order` must be at most the degree {cp.shape[-2] - 1} of the curve, got {order}"
        )
    return _derivative_kernel(cp, order)


@functools.partial(jax.jit, static_argnums=1)
def _derivative_kernel(cp: jax.Array, order: int) -> jax.Array:
    for _ in range(order):
        n = cp.shape[-2] - 1
        cp = n * (cp[..., 1:, :] - cp[..., :-1, :])
    return cp


def _bezier_points(control_points: Float[ArrayLike, "*batch n+1 d"]) -> jax.Array:
    return _control_points(control_points)


class Bezier(eqx.Module):
    """A Bezier curve as a pytree, so `gfxlab.fit.fit` can fit its control points.

    **Fields:** `control_points` `(..., n+1, d)`. Call with `u` `(N,)` in `[0, 1]`.
    """

    control_points: Float[Array, "*batch n+1 d"] = eqx.field(converter=_bezier_points)

    @property
    def degree(self) -> int:
        return self.control_points.shape[-2] - 1

    def __call__(self, u: Float[ArrayLike, " N"]) -> Float[Array, "*batch N d"]:
        return bezier(self.control_points, u)

    def derivative(self, *, order: int = 1) -> Bezier:
        """The derivative curve `P^(order)(u)` as a `Bezier`."""
        return Bezier(derivative(self.control_points, order=order))

    def split(self, t: Float[ArrayLike, ""] = 0.5) -> tuple[Bezier, Bezier]:
        """The pieces on `[0, t]` and `[t, 1]`."""
        left, right = split(self.control_points, t)
        return Bezier(left), Bezier(right)

    def elevate_degree(self, *, times: int = 1) -> Bezier:
        """The same curve with `times` more control points."""
        return Bezier(elevate_degree(self.control_points, times=times))
