"""B-spline knot vectors: uniform and clamped knots, checks, parameter range, span search."""

from __future__ import annotations

import functools

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
    return _clamped_knots(n, p, _float_dtype(dtype))


@functools.lru_cache(maxsize=64)
def _clamped_knots(n: int, p: int, dtype) -> jax.Array:
    """Cached (a JAX array is immutable): the default knots of `bspline` cost no
    dispatch on repeated eager calls."""
    interior = np.arange(1, n - p) / (n - p)
    knots = np.concatenate([np.zeros(p + 1), interior, np.ones(p + 1)])
    with jax.ensure_compile_time_eval():
        return jnp.asarray(knots, dtype=dtype)


def _check_degree(num_control_points, degree) -> tuple[int, int]:
    n = static_int(num_control_points, "num_control_points", minimum=1, maximum=MAX_CONTROL_POINTS)
    p = static_int(degree, "degree", minimum=0, maximum=MAX_BSPLINE_DEGREE)
    if p > n - 1:
        raise ValueError(
            f"`degree` {p} is too high for {n} control points: a B-spline of degree p "
            f"needs at least p + 1 control points (degree <= {n - 1} here)"
        )
    return n, p


def _check_knot_count(knots: jax.Array, degree: int, num_control_points: int) -> None:
    """The static part of `_check_knots`: a 1-D array of `n + p + 1` knots."""
    check_shape(knots, "knots", (None,))
    expected = num_control_points + degree + 1
    if knots.shape[0] != expected:
        raise ValueError(
            f"`knots` must have num_control_points + degree + 1 = {num_control_points} + "
            f"{degree} + 1 = {expected} entries, got {knots.shape[0]}"
        )


def _check_knots(knots: jax.Array, degree: int, num_control_points: int) -> jax.Array:
    _check_knot_count(knots, degree, num_control_points)
    checks = [
        ("`knots` must be finite (no NaN or inf)", _not_finite),
        ("`knots` must be non-decreasing (t_0 <= t_1 <= ... <= t_m)", lambda t: t[1:] < t[:-1]),
        (
            f"`knots` give an empty parameter range: t_p = t_{degree} must be less than "
            f"t_n = t_{num_control_points}",
            lambda t: t[degree] >= t[num_control_points],
        ),
    ]
    if not is_traced(knots):  # one conversion, NumPy checks: no dispatch
        values = np.asarray(knots)
        for message, bad in checks:
            if np.asarray(bad(values)).any():
                raise ValueError(message)
        return knots
    for message, bad in checks:
        knots = _require(knots, message, bad)
    return knots


def parameter_range(
    knots: Float[ArrayLike, " m+1"], degree: int
) -> tuple[Float[Array, ""], Float[Array, ""]]:
    """The valid parameter range `(t_p, t_n)` of a degree-`p` B-spline with these knots
    (`n = m - p` control points): where the basis functions sum to one.

    **Raises:** `ValueError` for knots that are not finite and non-decreasing, or that
    leave an empty range (`t_p = t_n`); `TypeError` for `None` or a degree that is not a whole
    number (2 and 2.0 are accepted).
    """
    knots = as_float(knots, "knots")
    check_shape(knots, "knots", (None,))
    p = static_int(degree, "degree", minimum=0, maximum=MAX_BSPLINE_DEGREE)
    if knots.shape[0] < p + 2:
        raise ValueError(
            f"`degree` {p} is too high for {knots.shape[0]} knots (need at least degree + 2)"
        )
    n = knots.shape[0] - p - 1
    return _range_kernel(_check_knots(knots, p, n), p, n)


@functools.partial(jax.jit, static_argnums=(1, 2))
def _range_kernel(knots: jax.Array, p: int, n: int) -> tuple[jax.Array, jax.Array]:
    return knots[p], knots[n]


def _check_in_range(
    u: jax.Array, knots: jax.Array, degree: int, n: int, name: str = "u"
) -> jax.Array:
    bounds = knots if is_traced(knots) else np.asarray(knots)  # no dispatch eagerly
    return _require_between(
        u,
        bounds[degree],
        bounds[n],
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


def _valid_spans(knots: jax.Array, degree: int, n: int) -> tuple[jax.Array, jax.Array]:
    """The first and last non-empty spans in `[p, n-1]`."""
    m = knots.shape[0] - 1
    index = jnp.arange(m)
    valid = (knots[1:] > knots[:-1]) & (index >= degree) & (index <= n - 1)
    return jnp.argmax(valid), m - 1 - jnp.argmax(valid[::-1])


def _spans(knots: jax.Array, degree: int, n: int, u: jax.Array) -> jax.Array:
    """For each `u`, the index `s` of its knot span, `t_s <= u < t_{s+1}`, restricted to
    non-empty spans in `[p, n-1]` (so `u = t_n` belongs to the last non-empty span)."""
    first, last = _valid_spans(knots, degree, n)
    return jnp.clip(_span_search(knots, u), first, last)


#: Most cells of the span look-up grid (`_cell_spans`); beyond, the binary search runs.
_MAX_CELLS = 1 << 16


def _cell_count(n: int, degree: int) -> int:
    """Cells of the span look-up grid for `n` control points: four per span, so that
    for knots no closer than a quarter of the mean spacing every cell meets at most two
    distinct knot values."""
    return min(4 * (n - degree), _MAX_CELLS)


def _cell_spans(knots: jax.Array, degree: int, n: int, cells: int):
    """A span look-up grid: `cells` uniform cells on the parameter range `[t_p, t_n]`.

    For cell `c` (widened by a few ulps on each side, so that rounding in `_cell_index`
    never puts a `u` in a cell that misses its knots), `b1[c] < b2[c]` are the first two
    distinct knot values from the cell's start on, and `spans[c]` the span of a `u` in
    the cell below `b1`, in `[b1, b2)` and at or above `b2` (clipped like `_spans`).
    Computed once per call from the knots alone (`O(cells log m)`).

    Returns `(origin, inverse cell width, b1, b2, spans (cells, 3), fits)`, where `fits`
    says that no cell meets a third distinct knot value; where it does not hold, use
    `_spans` (see `_bspline_kernel`).
    """
    first, last = _valid_spans(knots, degree, n)
    lo, hi = knots[degree], knots[n]
    slack = 64 * jnp.finfo(knots.dtype).eps * (jnp.abs(lo) + jnp.abs(hi))
    edges = lo + (hi - lo) * (jnp.arange(cells + 1, dtype=knots.dtype) / cells)
    padded = jnp.concatenate([knots, jnp.full((2,), jnp.inf, knots.dtype)])

    # Small tables: all comparisons at once (one fused pass, no loop); large: by sorting.
    method = "compare_all" if (cells + 1) * knots.shape[0] <= 1 << 20 else "sort"

    def count(x):  # how many knots are <= x
        return jnp.searchsorted(knots, x, side="right", method=method).astype(jnp.int32)

    below = count(edges[:-1] - slack)
    b1 = padded[below]
    past_b1 = count(b1)
    b2 = padded[past_b1]
    past_b2 = count(b2)
    fits = jnp.all(padded[past_b2] > edges[1:] + slack)
    spans = jnp.clip(jnp.stack([below, past_b1, past_b2], axis=-1) - 1, first, last)
    return lo, cells / (hi - lo), b1, b2, spans, fits


def _cell_index(u: jax.Array, origin, inverse_width, b1, b2, cells: int) -> jax.Array:
    """The row `3 c + j` of `u` in the tables of `_cell_spans`: its cell `c` and `j`, the
    number of the cell's two knot values at or below it (two 1-D look-ups, no search)."""
    cell = jnp.clip(((u - origin) * inverse_width).astype(jnp.int32), 0, cells - 1)
    above_b1 = u >= b1.at[cell].get(mode="promise_in_bounds")
    above_b2 = u >= b2.at[cell].get(mode="promise_in_bounds")
    return 3 * cell + above_b1.astype(jnp.int32) + above_b2.astype(jnp.int32)


# ----------------------------------------------------------------------------- closed


def periodic_breakpoints(num_control_points: int, *, dtype=None) -> Float[Array, " n+1"]:
    """Uniform breakpoints `0, 1/n, ..., 1` of a closed B-spline with `n` control points
    (one period, `u` in `[0, 1]`)."""
    n = static_int(num_control_points, "num_control_points", minimum=2, maximum=MAX_CONTROL_POINTS)
    return _periodic_breakpoints(n, _float_dtype(dtype))


@functools.lru_cache(maxsize=64)
def _periodic_breakpoints(n: int, dtype) -> jax.Array:
    with jax.ensure_compile_time_eval():  # cached: a constant, not a tracer
        return jnp.asarray(np.linspace(0, 1, n + 1), dtype=dtype)


def _check_breakpoint_count(breaks: jax.Array, n: int) -> None:
    """The static part of `_check_breakpoints`: a 1-D array of `n + 1` breakpoints."""
    check_shape(breaks, "knots", (None,))
    if breaks.shape[0] != n + 1:
        raise ValueError(
            f"`knots` of a closed B-spline are its num_control_points + 1 = {n + 1} "
            f"breakpoints (one period), got {breaks.shape[0]}"
        )


def _check_breakpoints(breaks: jax.Array, n: int) -> jax.Array:
    """Checks of the `n + 1` breakpoints `t_0 <= ... <= t_n` of a closed B-spline."""
    _check_breakpoint_count(breaks, n)
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


def _knots_field(knots) -> jax.Array:
    """The `base_knots` converter of `BSpline` and `NURBS`."""
    return as_float(knots, "knots")


def _check_knot_fields(curve, closed: bool = False) -> None:
    """The `__check_init__` of a curve's knots against its degree and control points
    (their number always; the values of traced knots when the curve is evaluated)."""
    n = curve.control_points.shape[-2]
    if is_traced(curve.base_knots):
        if closed:
            _check_breakpoint_count(curve.base_knots, n)
        else:
            _check_knot_count(curve.base_knots, curve.degree, n)
        return
    if closed:
        _check_breakpoints(curve.base_knots, n)
    else:
        _check_knots(curve.base_knots, curve.degree, n)


def _knots_in_use(base_knots: jax.Array, knot_logits, a: int, b: int) -> jax.Array:
    """The `knots` of a `BSpline` or `NURBS`: the given knots (behind `stop_gradient`),
    with the span `[t_a, t_b]` split by `knot_logits` when those are fitted."""
    frame = jax.lax.stop_gradient(base_knots)
    return frame if knot_logits is None else _knots_from_logits(frame, knot_logits, a, b)


def _initial_logits(knots: jax.Array, a: int, b: int) -> jax.Array:
    """`_knot_logits` of knots that `__check_init__` has not seen yet: it never raises
    (knots of a wrong shape give zeros, which `__check_init__` then refuses)."""
    if knots.ndim != 1 or knots.shape[0] <= b:
        return jnp.zeros((b - a,), knots.dtype)
    return _knot_logits(knots, a, b)


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
