"""B-spline curves: the Cox-de Boor basis, fast evaluation through Bezier spans, `BSpline`."""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import check_shape, static_int
from ._bezier import _bernstein
from ._common import (
    _control_points,
    _flat_parameters,
    _floats,
    _not_finite,
    _require,
    _safe_ratio,
    _unflatten,
)
from ._knots import (
    _cell_count,
    _cell_index,
    _cell_spans,
    _check_breakpoints,
    _check_degree,
    _check_in_range,
    _check_knot_fields,
    _check_knots,
    _initial_logits,
    _knots_field,
    _knots_in_use,
    _periodic_knots,
    _span_range,
    _spans,
    _wrap_parameters,
    clamped_knots,
    parameter_range,
    periodic_breakpoints,
)


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
    knots, u = _floats(knots, u, names=("knots", "u"))
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
    closed: bool = False,
) -> Float[Array, "*batch N d"]:
    """A B-spline curve `P(u) = sum_i N_{i,p}(u) p_i`, open or closed (periodic).

    Each `u` touches only the `p + 1` control points of its knot span (local control).
    Evaluation converts every span to Bezier form once (blossoming by de Boor's
    algorithm, `O(n p^3)`), then per `u` does a branch-free binary search for the span
    and a degree-`p` Bernstein evaluation: `O(N (log m + p d))`, one compiled program.
    It equals `bspline_basis(knots, degree, u) @ control_points` (the textbook
    Cox-de Boor form) and SciPy's `BSpline`.

    A **closed** B-spline (`closed=True`) is the open one of the wrapped control points
    `p_0..p_{n-1}, p_0..p_{p-1}` on the periodically extended breakpoints: a loop that is
    `C^{p-1}` everywhere, including where it closes, and any `u` is taken modulo the
    period (SciPy's `extrapolate="periodic"`).

    **Arguments:**

    - `control_points`: `(..., n, d)`, with `n >= degree + 1`, finite.
    - `degree`: `p`, a static int in `[0, MAX_BSPLINE_DEGREE]` (`p = 3` is the cubic
      B-spline; Hearn and Baker's degree parameter `d` is `p + 1`).
    - `u`: `(N,)` parameters in `parameter_range(knots, degree)` (any shape works); for
      a closed curve any finite `u` (wrapped into the period).
    - `knots`: open: `(n + p + 1,)` non-decreasing knots, default `clamped_knots(n, p)`
      (`u` in `[0, 1]`, the curve interpolates its end points). Closed: the `(n + 1,)`
      breakpoints `t_0 <= ... <= t_n` of one period, default uniform on `[0, 1]`.
    - `closed`: a closed (periodic) curve.

    **Returns:** `(..., N, d)`.

    **Raises:** `ValueError` when the degree is too high for the number of control
    points, the knots are decreasing, non-finite or the wrong length, or `u` is out of
    range or NaN (under `jit` through `equinox.error_if`); `TypeError` for `None` or a
    degree that is not a whole number (`3` and `3.0` are accepted, `3.5` and `True` not).
    """
    cp = _control_points(control_points)
    n, p = _check_degree(cp.shape[-2], degree)
    if closed:
        if knots is None:
            knots = periodic_breakpoints(n, dtype=cp.dtype)
        cp, knots, u = _floats(cp, knots, u, names=("control_points", "knots", "u"))
        knots = _check_breakpoints(knots, n)
        u = _require(u, "`u` must be finite (no NaN or inf)", _not_finite)
        return _closed_kernel(cp, knots, u, p)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    cp, knots, u = _floats(cp, knots, u, names=("control_points", "knots", "u"))
    knots = _check_knots(knots, p, n)
    u = _check_in_range(u, knots, p, n)
    return _bspline_kernel(cp, knots, u, p)


@functools.partial(jax.jit, static_argnums=3)
def _closed_kernel(cp: jax.Array, breaks: jax.Array, u: jax.Array, p: int) -> jax.Array:
    wrapped = jnp.concatenate([cp, cp[..., :p, :]], axis=-2)
    return _bspline_kernel(wrapped, _periodic_knots(breaks, p), _wrap_parameters(u, breaks), p)


#: Up to this degree `bspline` evaluates each span's polynomial in the power form by
#: Horner's rule (cheapest; for degree <= 5 its coefficients are within ~300x the control
#: points, so the rounding stays ~1e-14 relative); above it, in Bernstein form.
_POWER_DEGREE = 5


@functools.cache
def _power_coefficients(p: int) -> np.ndarray:
    """`(p+1, p+1)` matrix taking a span's Bezier points `b_j` to the coefficients `a_k`
    of `sum_k a_k x^k`, `x` the local parameter in `[0, 1]`:
    `a_k = C(p, k) sum_j C(k, j) (-1)^(k-j) b_j` (forward differences)."""
    matrix = np.zeros((p + 1, p + 1))
    for k in range(p + 1):
        for j in range(k + 1):
            matrix[k, j] = math.comb(p, k) * math.comb(k, j) * (-1) ** (k - j)
    return matrix


def _power_segments(cp: jax.Array, knots: jax.Array, p: int) -> tuple[jax.Array, jax.Array]:
    """Every span `s = p..n-1` as a polynomial in `u - t_s`: coefficients
    `(..., n-p, p+1, d)` (lowest power first) and the span starts `t_s`, `(n-p,)`."""
    n = cp.shape[-2]
    matrix = jnp.asarray(_power_coefficients(p), cp.dtype)
    power = jnp.einsum("kj,...sjd->...skd", matrix, _bezier_segments(cp, knots, p))
    starts = knots[p:n]
    inverse = _safe_ratio(jnp.ones_like(starts), knots[p + 1 : n + 1] - starts)
    scale = inverse[:, None] ** np.arange(p + 1)  # x^k = (u - t_s)^k / h^k
    return power * scale[..., None], starts


def _horner(coefficients: jax.Array, starts: jax.Array, row: jax.Array, u: jax.Array):
    """`sum_k c_k (u - t)^k` with the coefficients `(..., R, p+1, d)` and start `t` of
    table row `row` per `u` (`(N,)`): `(..., N, d)`.

    Each output column does 1-D look-ups of scalars (they fuse with the arithmetic into
    one pass over `u`); the columns are computed planar, `(..., d, N)`, then transposed.
    """
    p = coefficients.shape[-2] - 1

    def look_up(table):
        return table.at[row].get(mode="promise_in_bounds")

    x = u - look_up(starts)
    batch, dim = coefficients.shape[:-3], coefficients.shape[-1]
    columns = jnp.moveaxis(coefficients, -1, -3).reshape((-1,) + coefficients.shape[-3:-1])
    if columns.shape[0] <= 16:
        planar = []
        for column in columns:  # (R, p+1)
            value = look_up(column[:, p])
            for k in range(p - 1, -1, -1):
                value = value * x + look_up(column[:, k])
            planar.append(value)
        planar = jnp.stack(planar)
    else:  # many curves at once: gather whole rows
        rows = jnp.take(columns, row, axis=1, mode="clip")  # (B d, N, p+1)
        planar = rows[..., p]
        for k in range(p - 1, -1, -1):
            planar = planar * x + rows[..., k]
    return jnp.swapaxes(planar.reshape(batch + (dim, u.shape[0])), -1, -2)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _bspline_kernel(
    cp: jax.Array, knots: jax.Array, u: jax.Array, p: int, path: str = "auto"
) -> jax.Array:
    """`bspline` unchecked, one compiled program.

    Up to `_POWER_DEGREE`: the span polynomials in power form, re-tabulated per cell of
    the look-up grid of `_cell_spans` (so a `u` finds its coefficients through its cell
    and two comparisons: no search and no look-up of a look-up), then Horner's rule;
    when some cell meets more than two knot values (clustered knots), a binary search
    instead (`lax.cond`, decided once per call from the knots). `path="cells"` or
    `"search"` takes one branch only (smaller programs, for callers that know it from
    concrete knots: `_lookup_path`).
    """
    flat, shape = _flat_parameters(u)
    n = cp.shape[-2]
    if p > _POWER_DEGREE:
        segment = (_spans(knots, p, n, flat) - p).astype(jnp.int32)
        return _bspline_from_segments(cp, knots, u, segment, p)
    coefficients, starts = _power_segments(cp, knots, p)
    cells = _cell_count(n, p)
    origin, inverse_width, b1, b2, spans, fits = _cell_spans(knots, p, n, cells)

    def by_cells():
        rows = spans.reshape(-1) - p  # the segment of every (cell, j)
        row = _cell_index(flat, origin, inverse_width, b1, b2, cells)
        return _horner(coefficients[..., rows, :, :], starts[rows], row, flat)

    def by_search():
        return _horner(coefficients, starts, _spans(knots, p, n, flat) - p, flat)

    if path == "auto":
        return _unflatten(jax.lax.cond(fits, by_cells, by_search), shape, -2)
    return _unflatten(by_cells() if path == "cells" else by_search(), shape, -2)


def _lookup_path(knots, p: int, n: int) -> str:
    """The branch `_bspline_kernel` takes for these concrete knots."""
    fits = _cells_fit(knots, p, n)
    return "cells" if p <= _POWER_DEGREE and bool(fits) else "search"


@functools.partial(jax.jit, static_argnums=(1, 2))
def _cells_fit(knots: jax.Array, p: int, n: int) -> jax.Array:
    return _cell_spans(knots, p, n, _cell_count(n, p))[-1]


def _bspline_from_segments(cp, knots, u, segment, p: int) -> jax.Array:
    flat, shape = _flat_parameters(u)
    n = cp.shape[-2]
    bezier_points = _bezier_segments(cp, knots, p)  # (..., n-p, p+1, d)
    starts, ends = knots[p:n], knots[p + 1 : n + 1]
    scale = _safe_ratio(jnp.ones_like(starts), ends - starts)

    def look_up(table):  # 1-D gathers by span: cheap, and they fuse with the arithmetic
        return table.at[segment].get(mode="promise_in_bounds")

    x = (flat - look_up(starts)) * look_up(scale)  # local parameter in [0, 1]
    basis = _bernstein(p, x)
    weights = [basis[:, j] for j in range(p + 1)]
    batch, dim = cp.shape[:-2], cp.shape[-1]
    columns = bezier_points.reshape((-1,) + bezier_points.shape[-3:])  # (B, n-p, p+1, d)
    if columns.shape[0] * dim <= 16:
        out = jnp.stack(
            [
                jnp.stack(
                    [
                        sum(w * look_up(c[:, j, i]) for j, w in enumerate(weights))
                        for i in range(dim)
                    ],
                    axis=-1,
                )
                for c in columns
            ]
        )
    else:  # many curves at once: gather whole segments
        rows = jnp.take(columns, segment, axis=1, mode="clip")  # (B, N, p+1, d)
        out = jnp.einsum("jn,bnjd->bnd", jnp.stack(weights), rows)
    return _unflatten(out.reshape(batch + flat.shape + (dim,)), shape, -2)


class BSpline(eqx.Module):
    """A B-spline curve as a pytree, open or closed.

    **Fields:**

    - `control_points`: `(..., n, d)`, fitted by `gfxlab.fit`.
    - `base_knots`: the knots as given (`(n + p + 1,)`; a closed curve's `(n + 1,)`
      breakpoints), held fixed: `fixed_fields()` names it, and it is behind
      `lax.stop_gradient` too.
    - `knot_logits`: with `fit_knots=True`, the logs of the span widths inside the
      parameter range, `(n - p,)` (closed: `(n,)`); `None` otherwise. The fitted knots
      split the fixed range `[t_p, t_n]` in proportions `softmax(knot_logits)`, so they
      stay increasing whatever the optimiser does (a monotone reparametrisation); the
      range itself and the knots outside it stay fixed.
    - `degree`, `fit_knots`, `closed`: static.

    The property `knots` is the knot vector in use. Call with `u` `(N,)`.
    """

    control_points: Float[Array, "*batch n d"] = eqx.field(converter=_control_points)
    base_knots: Float[Array, " k"] = eqx.field(converter=_knots_field)
    knot_logits: Float[Array, " s"] | None
    degree: int = eqx.field(static=True)
    fit_knots: bool = eqx.field(static=True)
    closed: bool = eqx.field(static=True)

    def __init__(
        self,
        control_points: Float[ArrayLike, "*batch n d"],
        degree: int,
        knots: Float[ArrayLike, " n+p+1"] | None = None,
        *,
        fit_knots: bool = False,
        closed: bool = False,
    ):
        # The fields computed from several arguments (default knots, `knot_logits`) are
        # made here, from the checked degree they need; `__check_init__` checks the knots.
        cp = _control_points(control_points)
        n, p = _check_degree(cp.shape[-2], degree)
        self.closed, self.fit_knots = bool(closed), bool(fit_knots)
        if knots is None:
            knots = (
                periodic_breakpoints(n, dtype=cp.dtype)
                if self.closed
                else clamped_knots(n, p, dtype=cp.dtype)
            )
        self.control_points, self.base_knots, self.degree = cp, _knots_field(knots), p
        a, b = _span_range(p, n, self.closed)
        self.knot_logits = _initial_logits(self.base_knots, a, b) if self.fit_knots else None

    def __check_init__(self):
        """The knots against the degree and the number of control points."""
        _check_knot_fields(self, self.closed)

    def fixed_fields(self) -> tuple[str, ...]:
        """Fields `gfxlab.fit` holds fixed: the given knots (with `fit_knots=True` the
        knots move through `knot_logits` instead, which stays free)."""
        return ("base_knots",)

    @property
    def knots(self) -> Float[Array, " k"]:
        """The knots in use (a closed curve's breakpoints)."""
        a, b = _span_range(self.degree, self.control_points.shape[-2], self.closed)
        return _knots_in_use(self.base_knots, self.knot_logits, a, b)

    @property
    def parameter_range(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        if self.closed:
            return self.base_knots[0], self.base_knots[-1]
        return parameter_range(self.base_knots, self.degree)

    def __call__(self, u: Float[ArrayLike, " N"]) -> Float[Array, "*batch N d"]:
        return bspline(self.control_points, self.degree, u, knots=self.knots, closed=self.closed)
