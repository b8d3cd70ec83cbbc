"""Circles and ellipses by the midpoint algorithms, vectorized and step by step.

The pixels of a circle or an ellipse depend on static ints only (radii): their
vectorized closed forms run in NumPy at trace time (a constant under `jit`, and no
compilation per radius in eager use). The stepwise `lax.scan` versions (`*_trace`,
`*_steps`) compile once per power-of-two scan length, not once per radius. A circle's
centre may be traced.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._checks import check_shape, static_int

__all__ = [
    "MAX_CIRCLE_RADIUS",
    "MAX_CENTER_COORDINATE",
    "midpoint_circle",
    "midpoint_circle_steps",
    "midpoint_circle_trace",
    "MAX_ELLIPSE_RADIUS",
    "midpoint_ellipse",
    "midpoint_ellipse_steps",
    "midpoint_ellipse_trace",
]

#: Largest radius of `midpoint_circle`: its exact integer tests use `4 r^2 < 2^31`.
MAX_CIRCLE_RADIUS = 16383
#: Largest semi-axis of `midpoint_ellipse`: its exact integer tests use `4 rx^2 ry^2 < 2^31`.
MAX_ELLIPSE_RADIUS = 128
#: Largest `|x|` or `|y|` of a circle's or ellipse's integer centre (a documented limit:
#: centre plus radius stays an int32).
MAX_CENTER_COORDINATE = 2**30

_INT = jnp.int32


def _isqrt(n, xp=jnp):
    """Exact integer square root `floor(sqrt(n))` of non-negative int32 values.

    `xp` is `numpy` or `jax.numpy`: the closed forms below run in NumPy when their inputs
    are static (a constant of the trace, no compilation) and in JAX when traced.
    """
    n = xp.maximum(n, 0)
    s = xp.floor(xp.sqrt(n.astype(np.float64 if xp is np else jnp.result_type(float))))
    s = s.astype(n.dtype)
    s = xp.where((s + 1) * (s + 1) <= n, s + 1, s)  # fix float rounding either way
    return xp.where(s * s > n, s - 1, s)


def _circle_octant_y(radius, x, xp=jnp):
    """y of the midpoint circle at column x (first octant), the closed form of its steps.

    The textbook recurrence keeps the midpoint below the chosen pixel inside the circle
    and the one above it outside or on it: `(2y - 1)^2 < 4 (r^2 - x^2) <= (2y + 1)^2`.
    """
    m = 4 * (radius * radius - x * x)
    s = xp.where(m >= 1, _isqrt(m - 1, xp), -1)  # largest s with s^2 < m
    return (s + 1) // 2


def _static_circle_octant(radius: int) -> np.ndarray:
    """First-octant pixels `(x, y)` with `x <= y` of the midpoint circle (NumPy)."""
    x = np.arange(radius + 1, dtype=np.int64)
    y = _circle_octant_y(np.int64(radius), x, np)
    octant = np.stack([x, y], -1)
    return octant[x <= y]


def _check_radius(radius, name: str, maximum: int) -> int:
    radius = static_int(radius, name, minimum=0)
    if radius > maximum:
        raise ValueError(f"`{name}` must be <= {maximum} (exact int32 arithmetic), got {radius}")
    return radius


def _check_center(center):
    """An integer centre: NumPy when concrete, a JAX array when traced."""
    if center is None:
        raise TypeError("`center` must be integer pixel coordinates (x, y), got None")
    center = center if isinstance(center, jax.Array) else np.asarray(center)
    check_shape(center, "center", (2,))
    if not jnp.issubdtype(center.dtype, jnp.integer):
        raise TypeError(
            f"`center` must be integer pixel coordinates (x, y), got dtype {center.dtype}"
        )
    if not isinstance(center, jax.core.Tracer) and np.any(
        np.abs(np.asarray(center).astype(np.int64)) > MAX_CENTER_COORDINATE
    ):
        raise ValueError(
            f"`center` must have |x|, |y| <= {MAX_CENTER_COORDINATE} (a documented limit: the "
            f"pixels are int32), got {np.asarray(center).tolist()}"
        )
    return center


def _offset(points: np.ndarray, center) -> jax.Array:
    """`points + center` as int32; in NumPy unless the centre is traced (no compiles)."""
    if isinstance(center, jax.core.Tracer):
        return jnp.asarray(points, _INT) + center.astype(_INT)
    return jax.device_put((points + np.asarray(center)).astype(np.int32))


def _symmetric_loop(path: np.ndarray) -> np.ndarray:
    """All pixels of a closed curve from its first-quadrant path, clockwise, no repeats.

    `path` runs clockwise from `(0, b)` (its only point with x = 0) to `(a, 0)` (its only
    point with y = 0). The four half-open quadrants `{x > 0, y >= 0}`, `{x >= 0, y < 0}`,
    `{x < 0, y <= 0}`, `{x <= 0, y > 0}` partition the plane without the origin, so the
    reflected copies below never repeat a pixel.
    """
    x, y = path[:, 0], path[:, 1]
    q1 = np.stack([x[1:], y[1:]], -1)
    q4 = np.stack([x[:-1], -y[:-1]], -1)[::-1]
    q3 = np.stack([-x[1:], -y[1:]], -1)
    q2 = np.stack([-x[:-1], y[:-1]], -1)[::-1]
    return np.concatenate([q1, q4, q3, q2])


def _circle_quadrant_path(octant: np.ndarray) -> np.ndarray:
    """First-quadrant path of a circle from its first-octant pixels `(x, y)`, `x <= y`."""
    strict = octant[octant[:, 0] < octant[:, 1]]
    diagonal = octant[octant[:, 0] == octant[:, 1]]
    mirrored = strict[::-1, ::-1]
    return np.concatenate([strict, diagonal, mirrored])


def _circle_from_octant(octant: np.ndarray, radius: int, center: jax.Array) -> jax.Array:
    if radius == 0:
        loop = np.zeros((1, 2), np.int32)
    else:
        loop = _symmetric_loop(_circle_quadrant_path(octant))
    return _offset(loop, center)


@functools.lru_cache(maxsize=64)
def _circle_loop(radius: int) -> np.ndarray:
    """The pixels of the midpoint circle of `radius` about the origin (cached, read-only)."""
    # NumPy only: this may run while a caller's `jit` traces (no device_put there).
    if radius == 0:
        loop = np.zeros((1, 2), np.int32)
    else:
        loop = _symmetric_loop(_circle_quadrant_path(_static_circle_octant(radius)))
        loop = loop.astype(np.int32)
    loop.flags.writeable = False
    return loop


def midpoint_circle(radius: int, *, center: tuple[int, int] = (0, 0)) -> Int[Array, "N 2"]:
    """The pixels of a circle by the midpoint circle algorithm, vectorized.

    The first octant (from `(0, r)` while `x <= y`) is computed in closed form: the
    midpoint algorithm keeps `(2y - 1)^2 < 4 (r^2 - x^2) <= (2y + 1)^2` at every column
    (see `midpoint_circle_steps` for the step-by-step version), so each column's `y` is
    an exact integer square root. The other seven octants follow by symmetry.

    **Arguments:**

    - `radius`: the radius, a static int in `[0, MAX_CIRCLE_RADIUS]`.
    - `center`: integer centre `(x, y)` (`|x|, |y| <= MAX_CENTER_COORDINATE`); may be
      a traced integer array.

    **Returns:** int32 `(N, 2)` unique pixel positions `(x, y)` in clockwise order,
    starting just right of the top pixel `(xc, yc + r)` and ending on it (for `r = 0`
    the single pixel `center`). `N = 4 (n - 1)` where `n` is the number of pixels in
    one quadrant.
    """
    radius = _check_radius(radius, "radius", MAX_CIRCLE_RADIUS)
    center = _check_center(center)
    # The pixels depend only on static ints: a constant of the trace, computed in NumPy.
    return _offset(_circle_loop(radius), center)


@jax.jit(static_argnames="length")  # compiled once per length
def _circle_trace_scan(radius: int, length: int) -> jax.Array:
    r = jnp.asarray(radius, _INT)

    def step(carry, k):
        x, y, p = carry
        x_next = x + 1
        keep = p < 0
        y_next = jnp.where(keep, y, y - 1)
        # p_{k+1} = p_k + 2 x_{k+1} + 1          if p_k < 0
        #         = p_k + 2 x_{k+1} + 1 - 2 y_{k+1}  otherwise
        p_next = jnp.where(keep, p + 2 * x_next + 1, p + 2 * x_next + 1 - 2 * y_next)
        return (x_next, y_next, p_next), jnp.stack([k, p, x_next, y_next])

    init = (jnp.asarray(0, _INT), r, 1 - r)
    _, rows = jax.lax.scan(step, init, jnp.arange(length, dtype=_INT))
    return rows


def _circle_num_steps(radius: int) -> int:
    """Steps of the midpoint loop `while x < y` (x_k = k): the columns with x < y(x)."""
    octant = _static_circle_octant(radius)
    return int(np.sum(octant[:, 0] < octant[:, 1]))


def _scan_length(steps: int) -> int:
    """The scan length compiled for `steps` steps: the next power of two, so that the
    stepwise versions compile a few times in all, not once per radius."""
    return 1 << max(steps - 1, 0).bit_length()


def _circle_trace_rows(radius: int) -> np.ndarray:
    steps = _circle_num_steps(radius)
    with jax.ensure_compile_time_eval():
        rows = np.asarray(_circle_trace_scan(radius, _scan_length(steps)))
    return rows[:steps]


def midpoint_circle_trace(radius: int) -> Int[Array, "K 4"]:
    """The midpoint circle algorithm's steps as the textbook tabulates them (`lax.scan`).

    Start at `(x_0, y_0) = (0, r)` with `p_0 = 1 - r`. While `x_k < y_k`: step to
    `x_{k+1} = x_k + 1`; if `p_k < 0` keep `y_{k+1} = y_k` and set
    `p_{k+1} = p_k + 2 x_{k+1} + 1`, else `y_{k+1} = y_k - 1` and
    `p_{k+1} = p_k + 2 x_{k+1} + 1 - 2 y_{k+1}`.

    For `r = 10` the rows are `k = 0..6` with `p_k = -9, -6, -1, 6, -3, 8, 5` and pixels
    `(1,10), (2,10), (3,10), (4,9), (5,9), (6,8), (7,7)`.

    **Arguments:**

    - `radius`: a static int in `[0, MAX_CIRCLE_RADIUS]`.

    **Returns:** int32 `(K, 4)` with columns `(k, p_k, x_{k+1}, y_{k+1})`.
    """
    radius = _check_radius(radius, "radius", MAX_CIRCLE_RADIUS)
    return jnp.asarray(_circle_trace_rows(radius))


def midpoint_circle_steps(radius: int, *, center: tuple[int, int] = (0, 0)) -> Int[Array, "N 2"]:
    """`midpoint_circle` from the step-by-step recurrence (`midpoint_circle_trace`).

    Same arguments and result (same pixels in the same order) as `midpoint_circle`.
    """
    radius = _check_radius(radius, "radius", MAX_CIRCLE_RADIUS)
    center = _check_center(center)
    rows = _circle_trace_rows(radius)
    octant = np.concatenate([np.array([[0, radius]]), rows[:, 2:4]])
    # The last step may overshoot the diagonal by one column: that pixel is the mirror
    # image of the one before it, which the symmetric copies already contain.
    octant = octant[octant[:, 0] <= octant[:, 1]]
    return _circle_from_octant(octant, radius, center)


def _check_ellipse_radii(rx, ry) -> tuple[int, int]:
    rx = static_int(rx, "rx", minimum=1)
    ry = static_int(ry, "ry", minimum=1)
    for value, name in ((rx, "rx"), (ry, "ry")):
        if value > MAX_ELLIPSE_RADIUS:
            raise ValueError(
                f"`{name}` must be <= {MAX_ELLIPSE_RADIUS} (exact int32 arithmetic), got {value}"
            )
    return rx, ry


@jax.jit(static_argnames="length")  # compiled once per length
def _ellipse_trace_scan(rx, ry, length: int) -> jax.Array:
    """The two-region midpoint ellipse loop over a fixed number of iterations.

    Rows `(region, k, P, frac, x_{k+1}, y_{k+1}, valid)`: the decision parameter is
    `p_k = P + frac / 4` with integer `P` (the fractions 1/4 of the textbook's initial
    values never change, because all increments are integers).
    """
    rx = jnp.asarray(rx, _INT)
    ry = jnp.asarray(ry, _INT)
    rx2, ry2 = rx * rx, ry * ry
    frac1 = rx2 % 4  # p1_0 = ry^2 - rx^2 ry + rx^2 / 4
    frac2 = ry2 % 4  # p2_0 = ry^2 (x + 1/2)^2 + rx^2 (y - 1)^2 - rx^2 ry^2

    def step(carry, _):
        x, y, p1, p2, region, k = carry
        in_region1 = (region == 1) & (ry2 * x < rx2 * y)
        switching = (region == 1) & ~in_region1
        p2 = jnp.where(
            switching, ry2 * (x * x + x) + ry2 // 4 + rx2 * (y - 1) * (y - 1) - rx2 * ry2, p2
        )
        k = jnp.where(switching, 0, k)
        region = jnp.where(switching, 2, region)
        in_region2 = (region == 2) & (y > 0)
        # Region 1: step x; p1 < 0 keeps y.  (p = P + frac/4 < 0  <=>  P < 0.)
        keep_y = p1 < 0
        x1 = x + 1
        y1 = jnp.where(keep_y, y, y - 1)
        p1_next = jnp.where(keep_y, p1 + 2 * ry2 * x1 + ry2, p1 + 2 * ry2 * x1 - 2 * rx2 * y1 + ry2)
        # Region 2: step y; p2 > 0 keeps x.  (P + frac/4 > 0  <=>  P >= 0 if frac else P > 0.)
        keep_x = jnp.where(frac2 > 0, p2 >= 0, p2 > 0)
        y2 = y - 1
        x2 = jnp.where(keep_x, x, x + 1)
        p2_next = jnp.where(keep_x, p2 - 2 * rx2 * y2 + rx2, p2 + 2 * ry2 * x2 - 2 * rx2 * y2 + rx2)
        valid = in_region1 | in_region2
        row = jnp.stack(
            [
                jnp.where(in_region1, 1, 2),
                k,
                jnp.where(in_region1, p1, p2),
                jnp.where(in_region1, frac1, frac2),
                jnp.where(in_region1, x1, x2),
                jnp.where(in_region1, y1, y2),
                valid.astype(_INT),
            ]
        )
        new = (
            jnp.where(in_region1, x1, jnp.where(in_region2, x2, x)),
            jnp.where(in_region1, y1, jnp.where(in_region2, y2, y)),
            jnp.where(in_region1, p1_next, p1),
            jnp.where(in_region2, p2_next, p2),
            region,
            jnp.where(valid, k + 1, k),
        )
        return new, row

    zero = jnp.asarray(0, _INT)
    init = (zero, ry, ry2 - rx2 * ry + rx2 // 4, zero, jnp.asarray(1, _INT), zero)
    _, rows = jax.lax.scan(step, init, None, length=length)
    return rows


def _ellipse_closed_form(rx, ry, length: int, xp=jnp):
    """The midpoint ellipse's first-quadrant pixels in closed form (fixed size + mask).

    Region 1 (x = k): `g(x)` is the y that keeps the midpoint below inside and the one
    above outside or on the ellipse; the loop may lag behind it by at most one pixel a
    step, so `y_k = max_{j <= k}(g(j) + j) - k` (a cumulative max). It ends at the first
    `k` with `ry^2 x_k >= rx^2 y_k`. Region 2 (y steps down): `h(y)` is the first x whose
    right midpoint is outside; the loop moves x by at most one pixel a step:
    `x_{j+1} = clip(h(y_{j+1}), x_j, x_j + 1)`, which (as x never has to move by more
    than one pixel in region 2) is `max(x_start, h(y))`.
    """
    dtype = np.int64 if xp is np else _INT
    rx = xp.asarray(rx, dtype)
    ry = xp.asarray(ry, dtype)
    rx2, ry2 = rx * rx, ry * ry
    k = xp.arange(length, dtype=dtype)
    # g(x): largest y with rx^2 (2y - 1)^2 < 4 ry^2 (rx^2 - x^2) =: M
    m = 4 * ry2 * (rx2 - k * k)
    t = xp.where(m >= 1, _isqrt((m - 1) // rx2, xp), -1)
    g = (t + 1) // 2
    cummax = np.maximum.accumulate if xp is np else jax.lax.cummax
    y1 = cummax(g + k) - k
    stop = ry2 * k >= rx2 * y1
    k_end = xp.argmax(stop)  # region 1 has points k = 0..k_end
    x_start, y_start = k_end, y1[k_end]
    # Region 2: y = y_start - j for j = 1..y_start
    y2 = y_start - (k + 1)
    n = 4 * rx2 * (ry2 - y2 * y2)
    u = _isqrt(xp.maximum(n, 0) // ry2, xp)
    h = (u + 1) // 2
    x2 = xp.maximum(x_start, h)
    xs = xp.concatenate([k, x2])
    ys = xp.concatenate([y1, y2])
    valid = xp.concatenate([k <= k_end, y2 >= 0])
    return xp.stack([xs, ys], -1), valid


def midpoint_ellipse(rx: int, ry: int, *, center: tuple[int, int] = (0, 0)) -> Int[Array, "N 2"]:
    """The pixels of an axis-aligned ellipse by the midpoint ellipse algorithm, vectorized.

    Both regions of the textbook algorithm (region 1 steps x while the slope is above
    -1, region 2 steps y down to 0) are evaluated in closed form; see
    `midpoint_ellipse_steps` for the step-by-step version.

    **Arguments:**

    - `rx`, `ry`: semi-axes, static ints in `[1, MAX_ELLIPSE_RADIUS]`.
    - `center`: integer centre `(x, y)` (`|x|, |y| <= MAX_CENTER_COORDINATE`); may be
      a traced integer array.

    **Returns:** int32 `(N, 2)` unique pixel positions `(x, y)` in clockwise order.
    """
    rx, ry = _check_ellipse_radii(rx, ry)
    center = _check_center(center)
    # The pixels depend only on static ints: a constant of the trace, computed in NumPy.
    points, valid = _ellipse_closed_form(rx, ry, max(rx, ry) + 1, np)
    path = points[valid]
    return _offset(_symmetric_loop(path), center)


def _ellipse_trace_rows(rx: int, ry: int) -> np.ndarray:
    with jax.ensure_compile_time_eval():
        rows = np.asarray(_ellipse_trace_scan(rx, ry, _scan_length(rx + ry + 2)))
    return rows[rows[:, 6] == 1]


def midpoint_ellipse_trace(rx: int, ry: int) -> Float[Array, "K 5"]:
    """The midpoint ellipse algorithm's steps as the textbook tabulates them (`lax.scan`).

    Region 1 starts at `(0, ry)` with `p1_0 = ry^2 - rx^2 ry + rx^2 / 4` and runs while
    `2 ry^2 x < 2 rx^2 y`: step x; if `p1 < 0` keep y, `p1 += 2 ry^2 x_{k+1} + ry^2`, else
    step y down, `p1 += 2 ry^2 x_{k+1} - 2 rx^2 y_{k+1} + ry^2`. Region 2 starts from the
    last point with `p2_0 = ry^2 (x + 1/2)^2 + rx^2 (y - 1)^2 - rx^2 ry^2` and runs while
    `y > 0`: step y down; if `p2 > 0` keep x, `p2 += rx^2 - 2 rx^2 y_{k+1}`, else step x,
    `p2 += 2 ry^2 x_{k+1} - 2 rx^2 y_{k+1} + rx^2`.

    For `rx = 8, ry = 6` region 1 gives `p = -332, -224, -44, 208, -108, 288, 244` and
    region 2 `p = -23, 361, 297` (Hearn and Baker's worked example).

    **Arguments:**

    - `rx`, `ry`: semi-axes, static ints in `[1, MAX_ELLIPSE_RADIUS]`.

    **Returns:** float `(K, 5)` with columns `(region, k, p_k, x_{k+1}, y_{k+1})`; `k`
    restarts at 0 in region 2 and `p_k` is exact (a multiple of 1/4).
    """
    rx, ry = _check_ellipse_radii(rx, ry)
    rows = _ellipse_trace_rows(rx, ry)
    p = rows[:, 2] + rows[:, 3] / 4.0
    table = np.stack([rows[:, 0], rows[:, 1], p, rows[:, 4], rows[:, 5]], -1)
    return jnp.asarray(table, jnp.result_type(float))


def midpoint_ellipse_steps(
    rx: int, ry: int, *, center: tuple[int, int] = (0, 0)
) -> Int[Array, "N 2"]:
    """`midpoint_ellipse` from the step-by-step recurrence (`midpoint_ellipse_trace`).

    Same arguments and result (same pixels in the same order) as `midpoint_ellipse`.
    """
    rx, ry = _check_ellipse_radii(rx, ry)
    center = _check_center(center)
    rows = _ellipse_trace_rows(rx, ry)
    path = np.concatenate([np.array([[0, ry]]), rows[:, 4:6]])
    return _offset(_symmetric_loop(path), center)
