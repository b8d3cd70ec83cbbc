"""Curves and surfaces: Bezier, de Casteljau, B-splines (Cox-de Boor), NURBS, the
parametric ellipse, tensor-product Bezier patches and the Utah teapot.

Conventions:

- Control points are arrays `(..., n+1, d)` (leading batch dimensions allowed); a
  curve evaluated at parameters `u` of shape `(N,)` gives points `(..., N, d)`. A
  scalar `u` drops the `N` axis; any other shape `U` gives `(..., *U, d)`.
- Degrees and counts are static Python ints; control points, weights, knots and
  parameters are traced and differentiable.
- A Bezier curve lives on `0 <= u <= 1`. A B-spline of degree `p` with knots
  `t_0 <= ... <= t_m` and `n = m - p` control points lives on `t_p <= u <= t_n`
  (`parameter_range`). Parameters outside the range raise `ValueError` (at once for
  concrete values, through `equinox.error_if` under `jit`).

Example:
    >>> import jax.numpy as jnp
    >>> from gfxlab import curves
    >>> abcd = jnp.array([[1, 1], [2, 3], [4, 3], [6, 4.0]])
    >>> curves.bezier(abcd, jnp.array([0, 0.25, 0.5, 0.75, 1]))  # the seed's question
"""

from __future__ import annotations

import functools
import math
import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from ._checks import (
    as_float,
    check_last_dim,
    check_shape,
    common_float,
    is_traced,
    static_int,
    value_error_if,
)

__all__ = [
    # Bezier
    "bernstein",
    "bezier",
    "de_casteljau",
    "split",
    "elevate_degree",
    "derivative",
    # B-splines and NURBS
    "uniform_knots",
    "clamped_knots",
    "parameter_range",
    "bspline_basis",
    "bspline",
    "nurbs",
    "nurbs_circle",
    # conics
    "ellipse",
    "circle",
    # surfaces
    "bezier_patch",
    "patch_mesh",
    "teapot_patches",
    "teapot",
    # modules
    "Bezier",
    "BSpline",
    "NURBS",
    "Ellipse",
    # fitting
    "chord_length_parameters",
    "fit_bezier",
    "fit_bspline",
    "fit_ellipse",
]

DATA_DIR = pathlib.Path(__file__).resolve().parents[1] / "data"


# ----------------------------------------------------------------------------- helpers


def _flat_parameters(u: jax.Array) -> tuple[jax.Array, tuple[int, ...]]:
    """`u` as a flat `(N,)` array and its original shape (to restore the output)."""
    return u.reshape(-1), tuple(u.shape)


def _unflatten(points: jax.Array, axis_size_shape: tuple[int, ...], axis: int) -> jax.Array:
    """Replace the flat parameter axis `axis` of `points` by the shape `axis_size_shape`."""
    axis = axis % points.ndim
    return points.reshape(points.shape[:axis] + axis_size_shape + points.shape[axis + 1 :])


def _require(x, message: str, bad, *context):
    """`x`, after raising `ValueError(message)` where `bad(x, *context)` holds.

    Concrete values are checked in NumPy (no JAX dispatch or compilation per shape);
    traced ones go through `value_error_if` (`equinox.error_if` under `jit`).
    """
    if is_traced((x, context)):
        return value_error_if(x, bad(x, *context), message)
    if np.any(bad(np.asarray(x), *(np.asarray(c) for c in context))):
        raise ValueError(message)
    return x


def _outside_unit_interval(u):
    return (u < 0) | (u > 1)


def _check_unit_interval(u: jax.Array, name: str = "u") -> jax.Array:
    return _require(
        u,
        f"`{name}` must lie in [0, 1], the parameter range of a Bezier curve",
        _outside_unit_interval,
    )


def _control_points(control_points, name: str = "control_points") -> jax.Array:
    cp = as_float(control_points, name)
    if cp.ndim < 2 or cp.shape[-2] < 1:
        raise ValueError(
            f"`{name}` must have shape (..., n+1, d): at least one point of dimension d, "
            f"got shape {tuple(cp.shape)}"
        )
    return cp


# ----------------------------------------------------------------------------- Bezier


def _bernstein(n: int, u: jax.Array) -> jax.Array:
    """All degree-`n` Bernstein polynomials at flat `u`, `(N, n+1)`, unchecked.

    Built by the recursion `B_{i,k} = (1-u) B_{i,k-1} + u B_{i-1,k-1}` (a `lax.scan`
    over the degree on a fixed `(N, n+1)` table whose entries `i > k` stay zero): every
    term is non-negative, so it is stable for any degree, and the gradient is finite
    everywhere, including at `u = 0` and `u = 1`.
    """
    w = u[:, None]
    basis = jnp.zeros(u.shape + (n + 1,), u.dtype).at[:, 0].set(1)

    def raise_degree(b, _):
        shifted = jnp.concatenate([jnp.zeros_like(b[:, :1]), b[:, :-1]], axis=1)
        return (1 - w) * b + w * shifted, None

    basis, _ = jax.lax.scan(raise_degree, basis, None, length=n)
    return basis


def bernstein(n: int, u: Float[ArrayLike, "*U"]) -> Float[Array, "*U n+1"]:
    """The Bernstein basis polynomials of degree `n`,
    `B_{i,n}(u) = C(n, i) u^i (1 - u)^(n - i)` for `i = 0..n`.

    **Arguments:**

    - `n`: the degree, a static int `>= 0`.
    - `u`: parameters in `[0, 1]`, usually `(N,)`.

    **Returns:** `(*u.shape, n+1)`; each row sums to one.
    """
    n = static_int(n, "n", minimum=0)
    u = _check_unit_interval(as_float(u, "u"))
    return _bernstein_kernel(n, u)


@functools.partial(jax.jit, static_argnums=0)
def _bernstein_kernel(n: int, u: jax.Array) -> jax.Array:
    return _bernstein(n, u.reshape(-1)).reshape(u.shape + (n + 1,))


@jax.jit
def _bezier_kernel(cp: jax.Array, u: jax.Array) -> jax.Array:
    flat, shape = _flat_parameters(u)
    basis = _bernstein(cp.shape[-2] - 1, flat)
    return _unflatten(jnp.einsum("nk,...kd->...nd", basis, cp), shape, -2)


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
    cp, u = common_float(cp, u, names=("control_points", "u"))
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
    cp, u = common_float(cp, u, names=("control_points", "u"))
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
    cp, t = common_float(cp, t, names=("control_points", "t"))
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

    **Returns:** `(..., n+1+times, d)` control points.
    """
    cp = _control_points(control_points)
    return _elevate_kernel(cp, static_int(times, "times", minimum=0))


@functools.partial(jax.jit, static_argnums=1)
def _elevate_kernel(cp: jax.Array, times: int) -> jax.Array:
    for _ in range(times):
        n = cp.shape[-2] - 1
        a = (jnp.arange(n + 2) / (n + 1)).astype(cp.dtype)[:, None]
        pad = jnp.zeros_like(cp[..., :1, :])
        previous = jnp.concatenate([pad, cp], axis=-2)  # p_{i-1}; weight 0 at i = 0
        current = jnp.concatenate([cp, pad], axis=-2)  # p_i; weight 0 at i = n+1
        cp = a * previous + (1 - a) * current
    return cp


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


# ----------------------------------------------------------------------------- B-splines


def _float_dtype(dtype):
    return jnp.result_type(float) if dtype is None else jnp.dtype(dtype)


def uniform_knots(num_control_points: int, degree: int, *, dtype=None) -> Float[Array, " m+1"]:
    """Uniform knots `0, 1, 2, ..., n + p` (Hearn and Baker's uniform B-spline).

    The curve lives on `degree <= u <= num_control_points` (`parameter_range`) and does
    not, in general, pass through its end control points.
    """
    n, p = _check_degree(num_control_points, degree)
    return jnp.arange(n + p + 1, dtype=_float_dtype(dtype))


def clamped_knots(num_control_points: int, degree: int, *, dtype=None) -> Float[Array, " m+1"]:
    """Clamped (open uniform) knots on `[0, 1]`: `p + 1` zeros, uniform interior knots,
    `p + 1` ones. The curve starts at the first control point and ends at the last.
    """
    n, p = _check_degree(num_control_points, degree)
    interior = np.arange(1, n - p) / (n - p)
    knots = np.concatenate([np.zeros(p + 1), interior, np.ones(p + 1)])
    return jnp.asarray(knots, dtype=_float_dtype(dtype))


def _check_degree(num_control_points, degree) -> tuple[int, int]:
    n = static_int(num_control_points, "num_control_points", minimum=1)
    p = static_int(degree, "degree", minimum=0)
    if p > n - 1:
        raise ValueError(
            f"`degree` {p} is too high for {n} control points: a B-spline of degree p "
            f"needs at least p + 1 control points (degree <= {n - 1} here)"
        )
    return n, p


def _check_knots(knots: jax.Array, degree: int, num_control_points: int) -> jax.Array:
    check_shape(knots, "knots", (None,))
    expected = num_control_points + degree + 1
    if knots.shape[0] != expected:
        raise ValueError(
            f"`knots` must have num_control_points + degree + 1 = {num_control_points} + "
            f"{degree} + 1 = {expected} entries, got {knots.shape[0]}"
        )
    knots = _require(
        knots,
        "`knots` must be non-decreasing (t_0 <= t_1 <= ... <= t_m)",
        lambda t: t[1:] < t[:-1],
    )
    return _require(
        knots,
        f"`knots` give an empty parameter range: t_p = t_{degree} must be less than "
        f"t_n = t_{num_control_points}",
        lambda t: t[degree] >= t[num_control_points],
    )


def parameter_range(
    knots: Float[ArrayLike, " m+1"], degree: int
) -> tuple[Float[Array, ""], Float[Array, ""]]:
    """The valid parameter range `(t_p, t_n)` of a degree-`p` B-spline with these knots
    (`n = m - p` control points): where the basis functions sum to one."""
    knots = as_float(knots, "knots")
    check_shape(knots, "knots", (None,))
    p = static_int(degree, "degree", minimum=0)
    if knots.shape[0] < p + 2:
        raise ValueError(
            f"`degree` {p} is too high for {knots.shape[0]} knots (need at least degree + 2)"
        )
    return knots[p], knots[knots.shape[0] - p - 1]


def _check_in_range(
    u: jax.Array, knots: jax.Array, degree: int, n: int, name: str = "u"
) -> jax.Array:
    return _require(
        u,
        f"`{name}` must lie in the B-spline's parameter range [t_p, t_n] (see "
        "`parameter_range`)",
        lambda u, t: (u < t[degree]) | (u > t[n]),
        knots,
    )


def _span_search(knots: jax.Array, u: jax.Array) -> jax.Array:
    """The largest `i` with `t_i <= u`, for sorted knots and `u >= t_0`: a branch-free
    binary search made of scalar look-ups, which XLA fuses into a few passes over `u`."""
    m = knots.shape[0]
    index = jnp.zeros(u.shape, jnp.int32)
    step = 1 << (max(m - 1, 1).bit_length() - 1)
    while step >= 1:
        candidate = jnp.minimum(index + step, m - 1)
        below = knots.at[candidate].get(mode="promise_in_bounds") <= u
        index = jnp.where(below, candidate, index)
        step //= 2
    return index


def _spans(knots: jax.Array, degree: int, n: int, u: jax.Array) -> jax.Array:
    """For each `u`, the index `s` of its knot span, `t_s <= u < t_{s+1}`, restricted to
    non-empty spans in `[p, n-1]` (so `u = t_n` belongs to the last non-empty span)."""
    m = knots.shape[0] - 1
    index = jnp.arange(m)
    valid = (knots[1:] > knots[:-1]) & (index >= degree) & (index <= n - 1)
    first = jnp.argmax(valid)
    last = m - 1 - jnp.argmax(valid[::-1])
    return jnp.clip(_span_search(knots, u), first, last)


def _bezier_segments(cp: jax.Array, knots: jax.Array, p: int) -> jax.Array:
    """The Bezier control points of every span `[t_s, t_{s+1}]`, `s = p..n-1`:
    `(..., n-p, p+1, d)`.

    Bezier point `k` of span `s` is the blossom of the curve at `k` copies of `t_{s+1}`
    and `p - k` copies of `t_s`, evaluated by de Boor's algorithm (level `r` blends
    `d_i = (1 - a) d_{i-1} + a d_i`, `a = (x_r - t_i) / (t_{i+p+1-r} - t_i)` with the
    `r`-th blossom argument `x_r`), vectorized over spans and `k`. For a non-empty span
    every denominator covers `[t_s, t_{s+1}]`, so it is positive; empty spans get
    finite values that are never used.
    """
    n = cp.shape[-2]
    s = np.arange(p, n)
    window = knots[s[:, None] + np.arange(-p, p + 1)]  # window[:, l] = t_{s-p+l}
    t_s, t_s1 = window[:, p], window[:, p + 1]
    k = np.arange(p + 1)
    d = cp[..., s[:, None] + np.arange(-p, 1), :][..., :, None, :, :]  # (..., S, 1, p+1, d)
    for r in range(1, p + 1):
        x = jnp.where(r <= k, t_s1[:, None], t_s[:, None])  # (S, p+1): argument r per k
        lo = window[:, r : p + 1]
        hi = window[:, p + 1 : 2 * p + 2 - r]
        a = _safe_ratio(x[:, :, None] - lo[:, None, :], (hi - lo)[:, None, :])[..., None]
        d = (1 - a) * d[..., :-1, :] + a * d[..., 1:, :]
    return d[..., 0, :]


def _safe_ratio(numerator: jax.Array, denominator: jax.Array) -> jax.Array:
    """`numerator / denominator`, with the B-spline convention `x / 0 = 0` (double
    `where`, so gradients stay finite)."""
    nonzero = denominator != 0
    return jnp.where(nonzero, numerator / jnp.where(nonzero, denominator, 1), 0)


def bspline_basis(
    knots: Float[ArrayLike, " m+1"], degree: int, u: Float[ArrayLike, " N"]
) -> Float[Array, "N n"]:
    """All B-spline basis functions `N_{i,p}(u)`, `i = 0..n-1` (`n = m - p`), by the
    Cox-de Boor recursion

    `N_{i,0}(u) = 1 if t_i <= u < t_{i+1} else 0`,
    `N_{i,k}(u) = (u - t_i) / (t_{i+k} - t_i) N_{i,k-1}(u)
    + (t_{i+k+1} - u) / (t_{i+k+1} - t_{i+1}) N_{i+1,k-1}(u)` (with `0/0 = 0`),

    vectorized over `u` and all knot spans and unrolled over `k = 1..p`. At the right
    end `u = t_n` the last non-empty span counts as containing `u`, so the functions
    sum to one on the closed range.

    **Arguments:**

    - `knots`: `(m+1,)` non-decreasing knots (repeats allowed), traced.
    - `degree`: `p`, a static int with `p <= m - 1`.
    - `u`: `(N,)` parameters in `parameter_range(knots, degree)` (any shape `U` works).

    **Returns:** `(N, n)` (or `(*U, n)`).
    """
    knots, u = common_float(knots, u, names=("knots", "u"))
    check_shape(knots, "knots", (None,))
    p = static_int(degree, "degree", minimum=0)
    if knots.shape[0] < p + 2:
        raise ValueError(
            f"`degree` {p} is too high for {knots.shape[0]} knots: a B-spline of degree p "
            "needs at least p + 2 knots (p + 1 control points)"
        )
    n = knots.shape[0] - p - 1
    knots = _check_knots(knots, p, n)
    u = _check_in_range(u, knots, p, n)
    return _bspline_basis_kernel(knots, u, p)


@functools.partial(jax.jit, static_argnums=2)
def _bspline_basis_kernel(knots: jax.Array, u: jax.Array, p: int) -> jax.Array:
    flat, shape = _flat_parameters(u)
    m = knots.shape[0] - 1
    n = m - p
    uu = flat[:, None]
    basis = jax.nn.one_hot(_spans(knots, p, n, flat), m, dtype=flat.dtype)  # N_{i,0}
    for k in range(1, p + 1):
        count = m - k  # functions N_{i,k}, i = 0..m-k-1
        t_i = knots[:count]
        t_ik = knots[k : k + count]
        t_i1 = knots[1 : 1 + count]
        t_ik1 = knots[k + 1 : k + 1 + count]
        rising = _safe_ratio(uu - t_i, t_ik - t_i)
        falling = _safe_ratio(t_ik1 - uu, t_ik1 - t_i1)
        basis = rising * basis[:, :-1] + falling * basis[:, 1:]
    return _unflatten(basis, shape, 0)


def bspline(
    control_points: Float[ArrayLike, "*batch n d"],
    degree: int,
    u: Float[ArrayLike, " N"],
    *,
    knots: Float[ArrayLike, " n+p+1"] | None = None,
) -> Float[Array, "*batch N d"]:
    """A B-spline curve `P(u) = sum_i N_{i,p}(u) p_i`.

    Each `u` touches only the `p + 1` control points of its knot span (local control).
    Evaluation converts every span to Bezier form once (blossoming by de Boor's
    algorithm, `O(n p^3)`), then per `u` does a branch-free binary search for the span
    and a degree-`p` Bernstein evaluation: `O(N (log m + p d))`, fused by XLA. It equals
    `bspline_basis(knots, degree, u) @ control_points` (the textbook Cox-de Boor form).

    **Arguments:**

    - `control_points`: `(..., n, d)`, with `n >= degree + 1`.
    - `degree`: `p`, a static int (`p = 3` is the cubic B-spline; Hearn and Baker's
      degree parameter `d` is `p + 1`).
    - `u`: `(N,)` parameters in `parameter_range(knots, degree)` (any shape works).
    - `knots`: `(n + p + 1,)` non-decreasing knots; default `clamped_knots(n, p)`, i.e.
      `u` in `[0, 1]` and the curve interpolates its end points.

    **Returns:** `(..., N, d)`.

    **Raises:** `ValueError` when the degree is too high for the number of control
    points, the knots are decreasing or the wrong length, or `u` is out of range.
    """
    cp = _control_points(control_points)
    n, p = _check_degree(cp.shape[-2], degree)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    cp, knots, u = common_float(cp, knots, u, names=("control_points", "knots", "u"))
    knots = _check_knots(knots, p, n)
    u = _check_in_range(u, knots, p, n)
    return _bspline_kernel(cp, knots, u, p)


def _bspline_kernel(cp: jax.Array, knots: jax.Array, u: jax.Array, p: int) -> jax.Array:
    # Two compiled programs, search then evaluation: on CPU, XLA compiles the pair into
    # code several times faster than the same work as a single program.
    segment = _segment_kernel(knots, u, p, cp.shape[-2])
    return _bspline_from_segments(cp, knots, u, segment, p)


@functools.partial(jax.jit, static_argnums=(2, 3))
def _segment_kernel(knots: jax.Array, u: jax.Array, p: int, n: int) -> jax.Array:
    """Index `s - p` of each `u`'s span among the spans `p..n-1`."""
    return (_spans(knots, p, n, u.reshape(-1)) - p).astype(jnp.int32)


@functools.partial(jax.jit, static_argnums=4)
def _bspline_from_segments(cp, knots, u, segment, p: int) -> jax.Array:
    flat, shape = _flat_parameters(u)
    n = cp.shape[-2]
    bezier_points = _bezier_segments(cp, knots, p)  # (..., n-p, p+1, d)
    starts, ends = knots[p:n], knots[p + 1 : n + 1]
    scale = _safe_ratio(jnp.ones_like(starts), ends - starts)

    def look_up(table):  # 1-D gathers by span: cheap, and they fuse with the arithmetic
        return table.at[segment].get(mode="promise_in_bounds")

    x = (flat - look_up(starts)) * look_up(scale)  # local parameter in [0, 1]
    y = 1 - x
    x_powers, y_powers = [jnp.ones_like(x)], [jnp.ones_like(x)]
    for _ in range(p):
        x_powers.append(x_powers[-1] * x)
        y_powers.append(y_powers[-1] * y)
    weights = [math.comb(p, j) * x_powers[j] * y_powers[p - j] for j in range(p + 1)]
    batch, dim = cp.shape[:-2], cp.shape[-1]
    columns = bezier_points.reshape((-1,) + bezier_points.shape[-3:])  # (B, n-p, p+1, d)
    if columns.shape[0] * dim <= 16:
        out = jnp.stack(
            [
                jnp.stack(
                    [sum(w * look_up(c[:, j, i]) for j, w in enumerate(weights))
                     for i in range(dim)],
                    axis=-1,
                )
                for c in columns
            ]
        )
    else:  # many curves at once: gather whole segments
        rows = jnp.take(columns, segment, axis=1, mode="clip")  # (B, N, p+1, d)
        out = jnp.einsum("jn,bnjd->bnd", jnp.stack(weights), rows)
    return _unflatten(out.reshape(batch + flat.shape + (dim,)), shape, -2)


def nurbs(
    control_points: Float[ArrayLike, "*batch n d"],
    weights: Float[ArrayLike, "*batch n"],
    degree: int,
    u: Float[ArrayLike, " N"],
    *,
    knots: Float[ArrayLike, " n+p+1"] | None = None,
) -> Float[Array, "*batch N d"]:
    """A rational B-spline (NURBS) `P(u) = sum_i N_{i,p}(u) w_i p_i / sum_i N_{i,p}(u) w_i`:
    a B-spline of the homogeneous points `(w_i p_i, w_i)` followed by the divide, so
    conics such as circles are exact (`nurbs_circle`).

    **Arguments:** as `bspline`, plus `weights` `(..., n)`, all positive.

    **Returns:** `(..., N, d)`.
    """
    cp = _control_points(control_points)
    cp, weights = common_float(cp, weights, names=("control_points", "weights"))
    if weights.shape != cp.shape[:-1]:
        raise ValueError(
            f"`weights` must have shape {tuple(cp.shape[:-1])} (one per control point), "
            f"got {tuple(weights.shape)}"
        )
    weights = _require(weights, "`weights` must all be positive", lambda w: w <= 0)
    n, p = _check_degree(cp.shape[-2], degree)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    cp, weights, knots, u = common_float(
        cp, weights, knots, u, names=("control_points", "weights", "knots", "u")
    )
    knots = _check_knots(knots, p, n)
    u = _check_in_range(u, knots, p, n)
    return _nurbs_kernel(cp, weights, knots, u, p)


@functools.partial(jax.jit, static_argnums=4)
def _nurbs_kernel(cp, weights, knots, u, p: int) -> jax.Array:
    homogeneous = jnp.concatenate([cp * weights[..., None], weights[..., None]], axis=-1)
    h = _bspline_kernel(homogeneous, knots, u, p)
    return h[..., :-1] / h[..., -1:]


def nurbs_circle(
    center: Float[ArrayLike, "2"] = (0.0, 0.0), radius: Float[ArrayLike, ""] = 1.0
) -> NURBS:
    """An exact circle as a quadratic NURBS: nine control points on the corners and edge
    midpoints of the circumscribed square, weights `1, 1/sqrt(2), 1, ...`, knots
    `0,0,0, 1/4,1/4, 1/2,1/2, 3/4,3/4, 1,1,1` (four 90-degree arcs).

    **Returns:** a `NURBS` on `u` in `[0, 1]`, starting and ending at
    `center + (radius, 0)` and running counter-clockwise (not at constant speed).
    """
    center, radius = common_float(center, radius, names=("center", "radius"))
    check_shape(center, "center", (2,))
    check_shape(radius, "radius", ())
    square = jnp.array(
        [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0]],
        dtype=center.dtype,
    )
    corner = math.sqrt(0.5)
    weights = jnp.array([1, corner, 1, corner, 1, corner, 1, corner, 1], dtype=center.dtype)
    knots = jnp.array([0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1], dtype=center.dtype)
    return NURBS(center + radius * square, weights, 2, knots)


# ----------------------------------------------------------------------------- conics


def ellipse(
    center: Float[ArrayLike, "*batch 2"],
    radii: Float[ArrayLike, "*batch 2"],
    angle: Float[ArrayLike, "*batch"],
    t: Float[ArrayLike, " N"],
) -> Float[Array, "*batch N 2"]:
    """The parametric ellipse `x = h + a cos t, y = k + b sin t`, rotated by `angle`
    about its centre `(h, k)`:
    `(x, y) = (h, k) + R(angle) (a cos t, b sin t)`.

    **Arguments:**

    - `center`: `(h, k)`, `(..., 2)`.
    - `radii`: `(a, b)`, the semi-axes along the (rotated) x and y axes, `(..., 2)`.
    - `angle`: rotation in radians, `(...)`.
    - `t`: parameters `(N,)`; `0 <= t < 2 pi` traces the ellipse once.

    **Returns:** `(..., N, 2)`.
    """
    center, radii, angle, t = common_float(
        center, radii, angle, t, names=("center", "radii", "angle", "t")
    )
    check_last_dim(center, "center", (2,), "the centre (h, k)")
    check_last_dim(radii, "radii", (2,), "the semi-axes (a, b)")
    return _ellipse_kernel(center, radii, angle, t)


@jax.jit
def _ellipse_kernel(center, radii, angle, t) -> jax.Array:
    flat, shape = _flat_parameters(t)
    local_x = radii[..., None, 0] * jnp.cos(flat)
    local_y = radii[..., None, 1] * jnp.sin(flat)
    c, s = jnp.cos(angle)[..., None], jnp.sin(angle)[..., None]
    x = center[..., None, 0] + c * local_x - s * local_y
    y = center[..., None, 1] + s * local_x + c * local_y
    return _unflatten(jnp.stack([x, y], axis=-1), shape, -2)


def circle(
    center: Float[ArrayLike, "*batch 2"],
    radius: Float[ArrayLike, "*batch"],
    t: Float[ArrayLike, " N"],
) -> Float[Array, "*batch N 2"]:
    """The parametric circle `(h + r cos t, k + r sin t)`: an ellipse with `a = b = r`."""
    radius = as_float(radius, "radius")
    radii = jnp.stack([radius, radius], axis=-1)
    return ellipse(center, radii, jnp.zeros_like(radius), t)


# ----------------------------------------------------------------------------- surfaces


def bezier_patch(
    control_net: Float[ArrayLike, "*batch m+1 n+1 d"],
    u: Float[ArrayLike, " U"],
    v: Float[ArrayLike, " V"],
) -> Float[Array, "*batch U V d"]:
    """A tensor-product Bezier patch `S(u, v) = sum_ij B_{i,m}(u) B_{j,n}(v) p_ij` on the
    grid `u x v`.

    **Arguments:**

    - `control_net`: `(..., m+1, n+1, d)`; the first net axis goes with `u`.
    - `u`, `v`: `(U,)` and `(V,)` parameters in `[0, 1]`.

    **Returns:** `(..., U, V, d)`.
    """
    net = as_float(control_net, "control_net")
    if net.ndim < 3:
        raise ValueError(
            f"`control_net` must have shape (..., m+1, n+1, d), got {tuple(net.shape)}"
        )
    net, u, v = common_float(net, u, v, names=("control_net", "u", "v"))
    check_shape(u, "u", (None,))
    check_shape(v, "v", (None,))
    u = _check_unit_interval(u, "u")
    v = _check_unit_interval(v, "v")
    return _patch_kernel(net, u, v)


@jax.jit
def _patch_kernel(net, u, v) -> jax.Array:
    bu = _bernstein(net.shape[-3] - 1, u)
    bv = _bernstein(net.shape[-2] - 1, v)
    return jnp.einsum("ai,bj,...ijd->...abd", bu, bv, net)


def patch_mesh(
    control_nets: Float[ArrayLike, "P m+1 n+1 3"], resolution: int
) -> tuple[Float[Array, "V 3"], Int[Array, "F 3"]]:
    """Triangulate Bezier patches on a regular `(resolution + 1)^2` parameter grid each.

    **Arguments:**

    - `control_nets`: `(P, m+1, n+1, d)` (or one net `(m+1, n+1, d)`).
    - `resolution`: grid cells per side of a patch, a static int `>= 1`.

    **Returns:** `(vertices, faces)`: vertices `(P (r+1)^2, d)` (patch-major, then `u`,
    then `v`; shared patch edges are not merged) and int32 faces `(2 P r^2, 3)` indexing
    them. Each triangle winds counter-clockwise about `dS/du x dS/dv`.
    """
    nets = as_float(control_nets, "control_nets")
    if nets.ndim == 3:
        nets = nets[None]
    if nets.ndim != 4:
        raise ValueError(
            f"`control_nets` must have shape (P, m+1, n+1, d) or (m+1, n+1, d), got "
            f"{tuple(jnp.shape(control_nets))}"
        )
    r = static_int(resolution, "resolution", minimum=1)
    grid = jnp.linspace(0, 1, r + 1, dtype=nets.dtype)
    points = bezier_patch(nets, grid, grid)  # (P, r+1, r+1, d)
    num_patches = nets.shape[0]
    vertices = points.reshape(num_patches * (r + 1) ** 2, nets.shape[-1])
    i, j = np.meshgrid(np.arange(r), np.arange(r), indexing="ij")
    a = (i * (r + 1) + j).ravel()  # (u_i, v_j)
    b, d = a + 1, a + (r + 1)  # (u_i, v_j+1), (u_i+1, v_j)
    c = d + 1
    cell = np.concatenate([np.stack([a, d, c], -1), np.stack([a, c, b], -1)])
    base = (np.arange(num_patches) * (r + 1) ** 2)[:, None, None]
    faces = (cell[None] + base).reshape(-1, 3).astype(np.int32)
    return vertices, jnp.asarray(faces)


@functools.lru_cache(maxsize=1)
def _teapot_data() -> tuple[np.ndarray, np.ndarray]:
    path = DATA_DIR / "teapot" / "teapot.txt"
    rows = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            rows.append(line.split())
    num_patches = int(rows[0][1])
    patches = np.array(rows[1 : 1 + num_patches], dtype=np.int64)
    num_vertices = int(rows[1 + num_patches][1])
    start = 2 + num_patches
    vertices = np.array(rows[start : start + num_vertices], dtype=np.float64)
    if patches.shape != (num_patches, 16) or vertices.shape != (num_vertices, 3):
        raise ValueError(f"{path} is malformed")  # pragma: no cover - shipped data
    patches.setflags(write=False)
    vertices.setflags(write=False)
    return patches, vertices


def teapot_patches(*, dtype=None) -> Float[Array, "32 4 4 3"]:
    """The Utah teapot's 32 bicubic control nets (Newell 1975), from `data/teapot/`.

    z is up; the teapot stands on z = 0 and is about 6.5 wide and 3.15 tall.
    """
    patches, vertices = _teapot_data()
    return jnp.asarray(vertices[patches].reshape(-1, 4, 4, 3), dtype=_float_dtype(dtype))


def teapot(resolution: int = 8, *, dtype=None) -> tuple[Float[Array, "V 3"], Int[Array, "F 3"]]:
    """The Utah teapot as a triangle mesh: `patch_mesh(teapot_patches(), resolution)`
    with the winding flipped so that faces wind counter-clockwise seen from outside.

    **Returns:** `(vertices (32 (r+1)^2, 3), faces (64 r^2, 3) int32)`.
    """
    vertices, faces = patch_mesh(teapot_patches(dtype=dtype), resolution)
    return vertices, faces[:, ::-1]


# ----------------------------------------------------------------------------- modules


class Bezier(eqx.Module):
    """A Bezier curve as a pytree, so `gfxlab.fit.fit` can fit its control points.

    **Fields:** `control_points` `(..., n+1, d)`. Call with `u` `(N,)` in `[0, 1]`.
    """

    control_points: Float[Array, "*batch n+1 d"]

    def __init__(self, control_points: Float[ArrayLike, "*batch n+1 d"]):
        self.control_points = _control_points(control_points)

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


def _knots_for(cp: jax.Array, degree: int, knots) -> tuple[jax.Array, int]:
    n, p = _check_degree(cp.shape[-2], degree)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    knots = as_float(knots, "knots")
    if not is_traced(knots):
        knots = _check_knots(knots, p, n)
    return knots, p


class BSpline(eqx.Module):
    """A B-spline curve as a pytree.

    **Fields:** `control_points` `(..., n, d)`, `knots` `(n + p + 1,)`, `degree` (static),
    `fit_knots` (static). With `fit_knots=False` (default) the knots are held fixed
    under differentiation (`lax.stop_gradient`), so fitting the module fits the control
    points only; `fit_knots=True` lets gradients reach the knots too.
    """

    control_points: Float[Array, "*batch n d"]
    knots: Float[Array, " n+p+1"]
    degree: int = eqx.field(static=True)
    fit_knots: bool = eqx.field(static=True)

    def __init__(
        self,
        control_points: Float[ArrayLike, "*batch n d"],
        degree: int,
        knots: Float[ArrayLike, " n+p+1"] | None = None,
        *,
        fit_knots: bool = False,
    ):
        cp = _control_points(control_points)
        self.knots, self.degree = _knots_for(cp, degree, knots)
        self.control_points = cp
        self.fit_knots = bool(fit_knots)

    @property
    def parameter_range(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        return parameter_range(self.knots, self.degree)

    def __call__(self, u: Float[ArrayLike, " N"]) -> Float[Array, "*batch N d"]:
        knots = self.knots if self.fit_knots else jax.lax.stop_gradient(self.knots)
        return bspline(self.control_points, self.degree, u, knots=knots)


class NURBS(eqx.Module):
    """A rational B-spline as a pytree (see `nurbs`); knots are held fixed under
    differentiation unless `fit_knots=True`.

    **Fields:** `control_points` `(..., n, d)`, `weights` `(..., n)`, `knots`, `degree`.
    """

    control_points: Float[Array, "*batch n d"]
    weights: Float[Array, "*batch n"]
    knots: Float[Array, " n+p+1"]
    degree: int = eqx.field(static=True)
    fit_knots: bool = eqx.field(static=True)

    def __init__(self, control_points, weights, degree: int, knots=None, *, fit_knots=False):
        cp = _control_points(control_points)
        self.knots, self.degree = _knots_for(cp, degree, knots)
        self.control_points = cp
        self.weights = as_float(weights, "weights")
        self.fit_knots = bool(fit_knots)

    @property
    def parameter_range(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        return parameter_range(self.knots, self.degree)

    def __call__(self, u: Float[ArrayLike, " N"]) -> Float[Array, "*batch N d"]:
        knots = self.knots if self.fit_knots else jax.lax.stop_gradient(self.knots)
        return nurbs(self.control_points, self.weights, self.degree, u, knots=knots)


class Ellipse(eqx.Module):
    """The parametric ellipse of `ellipse` as a pytree.

    **Fields:** `center` `(2,)`, `radii` `(2,)` (semi-axes `a`, `b`), `angle` (radians).
    Call with `t` `(N,)` to get `(N, 2)` points.
    """

    center: Float[Array, "2"]
    radii: Float[Array, "2"]
    angle: Float[Array, ""]

    def __init__(self, center, radii, angle=0.0):
        self.center, self.radii, self.angle = common_float(
            center, radii, angle, names=("center", "radii", "angle")
        )
        check_shape(self.center, "center", (2,))
        check_shape(self.radii, "radii", (2,))
        check_shape(self.angle, "angle", ())

    def __call__(self, t: Float[ArrayLike, " N"]) -> Float[Array, "N 2"]:
        return ellipse(self.center, self.radii, self.angle, t)

    def normalized(self) -> Ellipse:
        """The same point set with `a >= b >= 0` and `angle` in `[0, pi)`."""
        return Ellipse(self.center, *_normalized_axes(self.radii, self.angle))


@jax.jit
def _normalized_axes(radii: jax.Array, angle: jax.Array) -> tuple[jax.Array, jax.Array]:
    a, b = jnp.abs(radii[0]), jnp.abs(radii[1])
    swap = b > a
    radii = jnp.where(swap, jnp.stack([b, a]), jnp.stack([a, b]))
    return radii, jnp.mod(angle + jnp.where(swap, jnp.pi / 2, 0.0), jnp.pi)


# ----------------------------------------------------------------------------- fitting


def chord_length_parameters(points: Float[ArrayLike, "N d"]) -> Float[Array, " N"]:
    """Parameters proportional to the cumulative chord length of a point sequence,
    from 0 to 1 (uniform when all points coincide)."""
    points = as_float(points, "points")
    check_shape(points, "points", (None, None))
    if points.shape[0] < 2:
        raise ValueError(f"`points` must hold at least 2 points, got {points.shape[0]}")
    return _chord_length_kernel(points)


@jax.jit
def _chord_length_kernel(points: jax.Array) -> jax.Array:
    steps = points[1:] - points[:-1]
    squared = jnp.sum(steps * steps, axis=-1)
    positive = squared > 0
    lengths = jnp.where(positive, jnp.sqrt(jnp.where(positive, squared, 1)), 0)
    cumulative = jnp.concatenate([jnp.zeros((1,), points.dtype), jnp.cumsum(lengths)])
    total = cumulative[-1]
    uniform = jnp.linspace(0, 1, points.shape[0], dtype=points.dtype)
    return jnp.where(total > 0, cumulative / jnp.where(total > 0, total, 1), uniform)


@functools.partial(jax.jit, static_argnums=2)
def _resample(points: jax.Array, parameters: jax.Array, count: int) -> jax.Array:
    """`count` points spread along the polyline through `points` at `parameters`."""
    lo, hi = parameters[0], parameters[-1]
    targets = jnp.linspace(0, 1, count, dtype=points.dtype) * (hi - lo) + lo
    return jax.vmap(lambda column: jnp.interp(targets, parameters, column), 1, 1)(points)


def _fit_curve(evaluate, start, points, parameters, lo, hi, correct, method, max_steps):
    """Least-squares control points for fixed parameters, then (optionally) joint
    Levenberg-Marquardt over control points and parameters (parameter correction).

    `evaluate(control_points, parameters)` is an unchecked kernel: the inputs were
    validated by the caller, which keeps the compiled solver small."""
    from .fit import fit

    def residuals(cp, t, data):
        return evaluate(cp, t) - data

    result = fit(residuals, start, args=(parameters, points), method=method, max_steps=max_steps)
    cp = result.params
    if correct:

        def joint_residuals(params, data):
            cp, t = params
            return evaluate(cp, jnp.clip(t, lo, hi)) - data

        result = fit(
            joint_residuals,
            (cp, parameters),
            args=(points,),
            method="levenberg_marquardt",
            max_steps=max_steps,
        )
        cp, parameters = result.params
        parameters = jnp.clip(parameters, lo, hi)
    return cp, parameters, result


def _fit_points(points, name="points") -> jax.Array:
    points = as_float(points, name)
    check_shape(points, name, (None, None))
    return points


def fit_bezier(
    points: Float[ArrayLike, "N d"],
    degree: int,
    *,
    parameters: Float[ArrayLike, " N"] | None = None,
    correct_parameters: bool = False,
    method: str = "gauss_newton",
    max_steps: int = 50,
    full_output: bool = False,
):
    """Fit a degree-`degree` Bezier curve to a sequence of points by least squares.

    The control points minimise `sum_k |P(u_k) - x_k|^2` (solved with `gfxlab.fit.fit`)
    for parameters `u_k` given, or by chord length. With `correct_parameters=True` the
    parameters are then optimised too (joint Levenberg-Marquardt), which moves each
    `u_k` towards the foot point of `x_k` on the curve and lowers the error further.

    **Arguments:**

    - `points`: `(N, d)` data in order along the curve, `N >= degree + 1`.
    - `degree`: a static int `>= 1`.
    - `parameters`: `(N,)` in `[0, 1]`; default chord-length parameters.
    - `correct_parameters`: optimise the parameters too.
    - `method`, `max_steps`: passed to `gfxlab.fit.fit` for the control-point fit.
    - `full_output`: also return the parameters and the last `FitResult`.

    **Returns:** a `Bezier`, or `(Bezier, parameters, FitResult)` with `full_output`.
    """
    points = _fit_points(points)
    degree = static_int(degree, "degree", minimum=1)
    if points.shape[0] < degree + 1:
        raise ValueError(
            f"`points` must hold at least degree + 1 = {degree + 1} points to fit a degree-"
            f"{degree} Bezier curve, got {points.shape[0]}"
        )
    if parameters is None:
        parameters = chord_length_parameters(points)
    parameters = _check_unit_interval(as_float(parameters, "parameters").astype(points.dtype),
                                      "parameters")
    check_shape(parameters, "parameters", (points.shape[0],))
    start = _resample(points, parameters, degree + 1)
    cp, parameters, result = _fit_curve(
        _bezier_kernel, start, points, parameters, 0.0, 1.0, correct_parameters, method,
        max_steps,
    )
    curve = Bezier(cp)
    return (curve, parameters, result) if full_output else curve


def fit_bspline(
    points: Float[ArrayLike, "N d"],
    degree: int,
    num_control_points: int,
    *,
    knots: Float[ArrayLike, " n+p+1"] | None = None,
    parameters: Float[ArrayLike, " N"] | None = None,
    correct_parameters: bool = False,
    method: str = "gauss_newton",
    max_steps: int = 50,
    full_output: bool = False,
):
    """Fit a B-spline with `num_control_points` control points to a sequence of points by
    least squares (the control points of `scipy.interpolate.make_lsq_spline` for the
    same knots and parameters).

    **Arguments:**

    - `points`: `(N, d)` data in order along the curve, `N >= num_control_points`.
    - `degree`, `num_control_points`: static ints, `degree < num_control_points`.
    - `knots`: `(num_control_points + degree + 1,)`; default `clamped_knots`.
    - `parameters`: `(N,)` in `parameter_range(knots, degree)`; default chord length
      mapped onto that range.
    - `correct_parameters`: then optimise the parameters too (joint Levenberg-Marquardt).
    - `method`, `max_steps`: passed to `gfxlab.fit.fit` for the control-point fit.
    - `full_output`: also return the parameters and the last `FitResult`.

    **Returns:** a `BSpline`, or `(BSpline, parameters, FitResult)` with `full_output`.
    """
    points = _fit_points(points)
    n, p = _check_degree(num_control_points, degree)
    if points.shape[0] < n:
        raise ValueError(
            f"`points` must hold at least num_control_points = {n} points, got "
            f"{points.shape[0]}"
        )
    if knots is None:
        knots = clamped_knots(n, p, dtype=points.dtype)
    knots = _check_knots(as_float(knots, "knots").astype(points.dtype), p, n)
    lo, hi = knots[p], knots[n]
    if parameters is None:
        parameters = lo + (hi - lo) * chord_length_parameters(points)
    parameters = _check_in_range(
        as_float(parameters, "parameters").astype(points.dtype), knots, p, n, "parameters"
    )
    check_shape(parameters, "parameters", (points.shape[0],))
    start = _resample(points, parameters, n)

    def evaluate(cp, t):  # inputs already checked; parameters stay clipped to the range
        return _bspline_kernel(cp, knots, t, p)

    cp, parameters, result = _fit_curve(
        evaluate, start, points, parameters, lo, hi, correct_parameters, method, max_steps
    )
    curve = BSpline(cp, p, knots)
    return (curve, parameters, result) if full_output else curve


def fit_ellipse(
    points: Float[ArrayLike, "N 2"],
    *,
    initial: Ellipse | None = None,
    method: str = "levenberg_marquardt",
    max_steps: int = 100,
    full_output: bool = False,
):
    """Fit an ellipse to noisy points by geometric least squares.

    Minimises `sum_k |E(t_k) - x_k|^2` over the ellipse (centre, semi-axes, angle) and
    one parameter `t_k` per point, so the residuals are true point-to-curve offsets
    at convergence. The start (unless `initial` is given) comes from the points'
    principal axes: centre = mean, axes along the covariance eigenvectors, semi-axes
    `sqrt(2 variance)` (exact for evenly spread points on an ellipse).

    **Arguments:**

    - `points`: `(N, 2)`, `N >= 5`, in any order.
    - `initial`: a starting `Ellipse`.
    - `method`, `max_steps`: passed to `gfxlab.fit.fit`.
    - `full_output`: also return the parameters `t_k` and the `FitResult`.

    **Returns:** the fitted `Ellipse`, normalised (`a >= b`, angle in `[0, pi)`), or
    `(Ellipse, t, FitResult)` with `full_output`.
    """
    from .fit import fit

    points = _fit_points(points)
    check_last_dim(points, "points", (2,), "2D points")
    if points.shape[0] < 5:
        raise ValueError(f"`points` must hold at least 5 points to fix an ellipse, got "
                         f"{points.shape[0]}")
    if initial is None:
        initial = Ellipse(*_principal_axes(points))
    t = _ellipse_parameters(initial, points)

    def residuals(params, data):
        shape, t = params
        return shape(t) - data

    result = fit(residuals, (initial, t), args=(points,), method=method, max_steps=max_steps)
    fitted, t = result.params
    normalized = fitted.normalized()
    if full_output:
        # The parameters of the same points on the normalised ellipse.
        return normalized, _ellipse_parameters(normalized, fitted(t)), result
    return normalized


@jax.jit
def _principal_axes(points: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Centre, semi-axes and angle of the ellipse with the points' mean and covariance
    (points spread evenly in `t` over an ellipse have variance `a^2 / 2` along it)."""
    center = jnp.mean(points, axis=0)
    offsets = points - center
    variances, axes = jnp.linalg.eigh(offsets.T @ offsets / points.shape[0])
    major = axes[:, 1]
    angle = jnp.arctan2(major[1], major[0])
    radii = jnp.sqrt(2 * jnp.maximum(variances[::-1], 1e-12))
    return center, radii, angle


@eqx.filter_jit
def _ellipse_parameters(shape: Ellipse, points: jax.Array) -> jax.Array:
    """The parameter `t` of each point's direction in the ellipse's own frame (exact for
    points on the ellipse)."""
    c, s = jnp.cos(shape.angle), jnp.sin(shape.angle)
    offsets = points - shape.center
    local_x = c * offsets[:, 0] + s * offsets[:, 1]
    local_y = -s * offsets[:, 0] + c * offsets[:, 1]
    return jnp.arctan2(local_y / shape.radii[1], local_x / shape.radii[0])
