"""B-spline knot vectors: uniform and clamped knots, checks, parameter range, span search."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_shape, is_traced, static_int
from ._common import (
    MAX_BSPLINE_DEGREE,
    MAX_CONTROL_POINTS,
    _float_dtype,
    _not_finite,
    _require,
    _require_between,
)


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
    n = static_int(num_control_points, "num_control_points", minimum=1, maximum=MAX_CONTROL_POINTS)
    p = static_int(degree, "degree", minimum=0, maximum=MAX_BSPLINE_DEGREE)
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
    knots = _require(knots, "`knots` must be finite (no NaN or inf)", _not_finite)
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
    (`n = m - p` control points): where the basis functions sum to one.

    **Raises:** `ValueError` for knots that are not finite and non-decreasing, or that
    leave an empty range (`t_p = t_n`); `TypeError` for `None` or a non-int degree.
    """
    knots = as_float(knots, "knots")
    check_shape(knots, "knots", (None,))
    p = static_int(degree, "degree", minimum=0, maximum=MAX_BSPLINE_DEGREE)
    if knots.shape[0] < p + 2:
        raise ValueError(
            f"`degree` {p} is too high for {knots.shape[0]} knots (need at least degree + 2)"
        )
    n = knots.shape[0] - p - 1
    knots = _check_knots(knots, p, n)
    return knots[p], knots[n]


def _check_in_range(
    u: jax.Array, knots: jax.Array, degree: int, n: int, name: str = "u"
) -> jax.Array:
    return _require_between(
        u,
        knots[degree],
        knots[n],
        f"`{name}` must lie in the B-spline's parameter range [t_p, t_n] (see `parameter_range`)",
    )


def _span_search(knots: jax.Array, u: jax.Array) -> jax.Array:
    """The largest `i` with `t_i <= u`, for sorted knots and `u >= t_0`: a branch-free
    binary search of `log2(m)` halving steps.

    The steps run in a `lax.fori_loop` on purpose: each step is one fused pass over `u`
    (a scalar look-up, a compare, a select), and the loop keeps XLA from fusing the whole
    search into its consumers, where it would be recomputed for every output element
    (about 4x slower on CPU, measured in `tests/benchmarks/bench_curves.py`).
    """
    m = knots.shape[0]
    first = 1 << (max(m - 1, 1).bit_length() - 1)

    def halve(k, index):
        candidate = jnp.minimum(index + jnp.right_shift(first, k), m - 1)
        below = knots.at[candidate].get(mode="promise_in_bounds") <= u
        return jnp.where(below, candidate, index)

    return jax.lax.fori_loop(0, first.bit_length(), halve, jnp.zeros(u.shape, jnp.int32))


def _spans(knots: jax.Array, degree: int, n: int, u: jax.Array) -> jax.Array:
    """For each `u`, the index `s` of its knot span, `t_s <= u < t_{s+1}`, restricted to
    non-empty spans in `[p, n-1]` (so `u = t_n` belongs to the last non-empty span)."""
    m = knots.shape[0] - 1
    index = jnp.arange(m)
    valid = (knots[1:] > knots[:-1]) & (index >= degree) & (index <= n - 1)
    first = jnp.argmax(valid)
    last = m - 1 - jnp.argmax(valid[::-1])
    return jnp.clip(_span_search(knots, u), first, last)


def _knots_for(cp: jax.Array, degree: int, knots) -> tuple[jax.Array, int]:
    n, p = _check_degree(cp.shape[-2], degree)
    if knots is None:
        knots = clamped_knots(n, p, dtype=cp.dtype)
    knots = as_float(knots, "knots")
    if not is_traced(knots):
        knots = _check_knots(knots, p, n)
    return knots, p


# ----------------------------------------------------------------------------- closed


def periodic_breakpoints(num_control_points: int, *, dtype=None) -> Float[Array, " n+1"]:
    """Uniform breakpoints `0, 1/n, ..., 1` of a closed B-spline with `n` control points
    (one period, `u` in `[0, 1]`)."""
    n = static_int(num_control_points, "num_control_points", minimum=2, maximum=MAX_CONTROL_POINTS)
    return jnp.linspace(0, 1, n + 1, dtype=_float_dtype(dtype))


def _check_breakpoints(breaks: jax.Array, n: int) -> jax.Array:
    """Checks of the `n + 1` breakpoints `t_0 <= ... <= t_n` of a closed B-spline."""
    check_shape(breaks, "knots", (None,))
    if breaks.shape[0] != n + 1:
        raise ValueError(
            f"`knots` of a closed B-spline are its num_control_points + 1 = {n + 1} "
            f"breakpoints (one period), got {breaks.shape[0]}"
        )
    breaks = _require(breaks, "`knots` must be finite (no NaN or inf)", _not_finite)
    breaks = _require(
        breaks, "`knots` must be non-decreasing (t_0 <= ... <= t_n)", lambda t: t[1:] < t[:-1]
    )
    return _require(
        breaks, "`knots` must span a positive period: t_n > t_0", lambda t: t[-1] <= t[0]
    )


def _periodic_knots(breaks: jax.Array, p: int) -> jax.Array:
    """The `n + 2p + 1` knots of the open B-spline equal to a closed one: the period's
    breakpoints with `p` spans copied on each side, shifted by the period `T = t_n - t_0`
    (the control points wrap as `p_0..p_{n-1}, p_0..p_{p-1}`)."""
    n = breaks.shape[0] - 1
    period = breaks[n] - breaks[0]
    return jnp.concatenate([breaks[n - p : n] - period, breaks, breaks[1 : p + 1] + period])


def _wrap_parameters(u: jax.Array, breaks: jax.Array) -> jax.Array:
    """`u` mapped into the period `[t_0, t_n)` (periodic extrapolation)."""
    period = breaks[-1] - breaks[0]
    return breaks[0] + jnp.mod(u - breaks[0], period)


# ----------------------------------------------------------------------------- fitted knots


def _span_range(degree: int, num_control_points: int, closed: bool) -> tuple[int, int]:
    """Indices `(a, b)` of the knots bounding the parameter range: `(p, n)` for an open
    B-spline's knots, `(0, n)` for a closed one's breakpoints."""
    return (0, num_control_points) if closed else (degree, num_control_points)


def _knot_logits(knots: jax.Array, a: int, b: int) -> jax.Array:
    """Unconstrained parameters of the spans between knots `a` and `b`: the logs of their
    widths (spans narrower than `1e-9` of the range are floored there)."""
    widths = knots[a + 1 : b + 1] - knots[a:b]
    floor = 1e-9 * (knots[b] - knots[a])
    return jnp.log(jnp.maximum(widths, floor))


def _knots_from_logits(frame: jax.Array, logits: jax.Array, a: int, b: int) -> jax.Array:
    """The knots with interior `t_{a+1} .. t_{b-1}` set from span logits: the range
    `[t_a, t_b]` split in proportions `softmax(logits)`. Every span is positive, so the
    knots are increasing by construction whatever the logits (a monotone
    reparametrisation); the ends `t_a`, `t_b` and the knots outside stay as in `frame`."""
    fractions = jnp.cumsum(jax.nn.softmax(logits))[:-1]
    interior = frame[a] + (frame[b] - frame[a]) * fractions
    return jnp.concatenate([frame[: a + 1], interior, frame[b:]])
