"""Scan conversion on the pixel grid: lines, circles, ellipses, polygon fill,
anti-aliasing and a simulation of raster-scan and random-scan displays.

Pixel convention (used by every module and every plot): geometry is y up, and the
pixel in array column `col`, row `row` of an `(H, W)` image has its centre at the
integer point `(x, y) = (col, H - 1 - row)`; it covers `[x - 1/2, x + 1/2] x
[y - 1/2, y + 1/2]`. `pixel_to_index` and `index_to_pixel` convert, and
`image_extent` gives the matching `extent=` for `matplotlib.pyplot.imshow`.

Every stepwise textbook algorithm comes twice: a vectorized version for use (closed
forms over all steps at once) and a faithful step-by-step version (`*_steps`,
`*_trace`, built on `lax.scan`) that follows the textbook's decision parameters. The
tests check that the two agree exactly.

Sizes are static: line endpoints, radii and image shapes are Python ints, because
they fix how many pixels come out. The pixels of a line, circle or ellipse therefore
depend on static ints only: their vectorized closed forms run in NumPy at trace time
(a constant under `jit`, and no compilation per radius in eager use; the same closed
forms run in JAX on traced values, which is how the tests check them against the
`lax.scan` versions for hundreds of radii at once). Continuous inputs (polygon
vertices, the endpoints of the coverage functions, a circle's centre) may be traced;
the coverage functions are differentiable.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ._checks import (
    as_float,
    check_last_dim,
    check_shape,
    static_int,
    static_shape,
    value_error_if,
)
from ._pixels import image_extent, index_to_pixel, pixel_centers, pixel_to_index

__all__ = [
    "pixel_to_index",
    "index_to_pixel",
    "image_extent",
    "pixel_centers",
    "points_to_image",
    "line_dda",
    "line_dda_steps",
    "line_bresenham",
    "line_bresenham_steps",
    "MAX_CIRCLE_RADIUS",
    "midpoint_circle",
    "midpoint_circle_steps",
    "midpoint_circle_trace",
    "MAX_ELLIPSE_RADIUS",
    "midpoint_ellipse",
    "midpoint_ellipse_steps",
    "midpoint_ellipse_trace",
    "inside_polygon",
    "fill_polygon",
    "fill_polygon_scanline",
    "supersample",
    "polygon_coverage",
    "line_coverage",
    "BeamPath",
    "raster_scan",
    "random_scan",
    "phosphor_frames",
]

#: Largest radius of `midpoint_circle`: its exact integer tests use `4 r^2 < 2^31`.
MAX_CIRCLE_RADIUS = 16383
#: Largest semi-axis of `midpoint_ellipse`: its exact integer tests use `4 rx^2 ry^2 < 2^31`.
MAX_ELLIPSE_RADIUS = 128

_INT = jnp.int32


# --------------------------------------------------------------------------------------
# Pixel <-> array index
# --------------------------------------------------------------------------------------


def points_to_image(points: Int[Array, "*batch N 2"], shape: tuple[int, int]) -> Bool[Array, "H W"]:
    """Plot integer pixel positions `(x, y)` into a boolean `(H, W)` image.

    Points outside the image are dropped; leading batch dimensions are merged.

    **Arguments:**

    - `points`: integer pixel positions, shape `(..., N, 2)`.
    - `shape`: the image shape `(H, W)`.

    **Returns:** a boolean mask with `True` at every plotted pixel.
    """
    height, width = static_shape(shape)
    points = jnp.asarray(points)
    check_last_dim(points, "points", (2,), "pixel positions (x, y)")
    if not jnp.issubdtype(points.dtype, jnp.integer):
        raise TypeError(f"`points` must be integer pixel positions, got dtype {points.dtype}")
    points = points.reshape(-1, 2)
    rc = pixel_to_index(points, (height, width))
    inside = (rc[:, 0] >= 0) & (rc[:, 0] < height) & (rc[:, 1] >= 0) & (rc[:, 1] < width)
    # Send outside points out of bounds on the positive side, where `mode="drop"` drops
    # them (negative indices would wrap around).
    rows = jnp.where(inside, rc[:, 0], height)
    cols = jnp.where(inside, rc[:, 1], width)
    return jnp.zeros((height, width), bool).at[rows, cols].set(True, mode="drop")


# --------------------------------------------------------------------------------------
# Lines
# --------------------------------------------------------------------------------------


def _static_point(p, name: str) -> tuple[int, int]:
    if isinstance(p, jax.core.Tracer):
        raise TypeError(
            f"`{name}` fixes how many pixels the line has, so it must be static: a pair of "
            "Python ints, not a traced array"
        )
    try:
        items = list(np.asarray(p).tolist()) if not isinstance(p, tuple | list) else list(p)
    except TypeError as err:
        raise TypeError(f"`{name}` must be a pair of ints (x, y), got {p!r}") from err
    if len(items) != 2:
        raise ValueError(f"`{name}` must be a pair of ints (x, y), got {p!r}")
    return static_int(items[0], f"{name}[0]"), static_int(items[1], f"{name}[1]")


def _line_setup(p0, p1):
    """Static description of a line: major axis, step counts and signs."""
    x0, y0 = _static_point(p0, "p0")
    x1, y1 = _static_point(p1, "p1")
    dx, dy = x1 - x0, y1 - y0
    x_major = abs(dx) >= abs(dy)
    d_major, d_minor = (abs(dx), abs(dy)) if x_major else (abs(dy), abs(dx))
    s_major = 1 if (dx if x_major else dy) >= 0 else -1
    s_minor = 1 if (dy if x_major else dx) >= 0 else -1
    return (x0, y0), x_major, d_major, d_minor, s_major, s_minor


def _assemble_line(start, x_major, major_offset, minor_offset):
    # NumPy offsets (static lines) stay in NumPy: eager JAX ops would compile per length.
    xp = np if isinstance(major_offset, np.ndarray) else jnp
    x0, y0 = start
    if x_major:
        xy = xp.stack([x0 + major_offset, y0 + minor_offset], axis=-1)
    else:
        xy = xp.stack([x0 + minor_offset, y0 + major_offset], axis=-1)
    return jax.device_put(xy.astype(np.int32)) if xp is np else xy.astype(_INT)


def _dda_offsets(d_major, d_minor, k, xp=jnp):
    """DDA minor offsets after `k` major steps: `k dminor / dmajor` rounded half up.

    The float quotient of two small integers is exact at every half-way point, so ties
    always round away from the start.
    """
    dtype = np.float64 if xp is np else jnp.result_type(float)
    frac = (k * d_minor).astype(dtype) / xp.maximum(d_major, 1)
    return xp.floor(frac + 0.5).astype(k.dtype)


def _bresenham_offsets(d_major, d_minor, k):
    """Bresenham minor offsets after `k` major steps (closed form of the recurrence)."""
    return (2 * k * d_minor + d_major) // np.maximum(2 * d_major, 1)


@jax.jit(static_argnames="length")  # compiled once per length
def _dda_scan(d_major, d_minor, length: int):
    """Stepwise DDA along (major, minor): per step add the increments, then round.

    The increments `1` and `dminor / dmajor` are kept as exact fixed-point numerators
    over `dmajor` (an integer add per step), so no round-off accumulates.
    """
    denom = jnp.maximum(d_major, 1)
    float_dtype = jnp.result_type(float)

    def step(carry, _):
        major_num, minor_num = carry  # positions times `denom`
        major = jnp.floor(major_num.astype(float_dtype) / denom + 0.5).astype(_INT)
        minor = jnp.floor(minor_num.astype(float_dtype) / denom + 0.5).astype(_INT)
        return (major_num + d_major, minor_num + d_minor), (major, minor)

    init = (jnp.asarray(0, _INT), jnp.asarray(0, _INT))
    _, (major, minor) = jax.lax.scan(step, init, None, length=length)
    return major, minor


@jax.jit(static_argnames="length")  # compiled once per length
def _bresenham_scan(d_major, d_minor, length: int):
    """Textbook Bresenham along (major, minor) with the integer decision parameter."""

    def step(carry, _):
        major, minor, p = carry
        up = p >= 0
        next_minor = jnp.where(up, minor + 1, minor)
        next_p = jnp.where(up, p - 2 * d_major, p) + 2 * d_minor
        return (major + 1, next_minor, next_p), (major, minor)

    init = (jnp.asarray(0, _INT), jnp.asarray(0, _INT),
            jnp.asarray(2 * d_minor - d_major, _INT))
    _, (major, minor) = jax.lax.scan(step, init, None, length=length)
    return major, minor


def line_dda(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Digital differential analyser (DDA) line from `p0` to `p1`, vectorized.

    Steps one pixel at a time along the major axis (the one with the larger change)
    and moves `dminor / dmajor` along the other, rounding to the nearest pixel; an
    exact tie (a half-way point) rounds away from `p0`, so the result equals
    Bresenham's line (and `skimage.draw.line`) pixel for pixel. The endpoints are
    static, so the pixels are a constant of the trace, computed in NumPy.

    **Arguments:**

    - `p0`, `p1`: integer endpoints `(x, y)` as Python ints (static).

    **Returns:** int32 `(N, 2)` pixel positions `(x, y)` from `p0` to `p1`, both
    included, `N = max(|dx|, |dy|) + 1`.
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    k = np.arange(d_major + 1, dtype=np.int64)
    minor = _dda_offsets(d_major, d_minor, k, np)
    return _assemble_line(start, x_major, s_major * k, s_minor * minor)


def line_dda_steps(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Stepwise DDA (`lax.scan`): `x += x_inc; y += y_inc; plot(round(x), round(y))`.

    The increments `dx / steps`, `dy / steps` are added once per step. They are kept
    as exact fixed-point numerators over `steps` (an integer add per step), so no
    floating-point round-off accumulates and ties round as in `line_dda`.
    Same arguments and result as `line_dda`.
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    major, minor = _dda_scan(d_major, d_minor, d_major + 1)
    return _assemble_line(start, x_major, s_major * major, s_minor * minor)


def line_bresenham(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Bresenham's integer line from `p0` to `p1`, vectorized, all octants.

    After `k` steps along the major axis, Bresenham's decision parameter has moved the
    minor coordinate `floor((2 k dminor + dmajor) / (2 dmajor))` pixels: the closed
    form of its integer recurrence (`line_bresenham_steps`). A decision parameter of
    exactly zero steps the minor coordinate, as in the textbook (`p_k < 0` keeps it).
    The endpoints are static, so the pixels are a constant of the trace (NumPy).

    **Arguments:**

    - `p0`, `p1`: integer endpoints `(x, y)` as Python ints (static).

    **Returns:** int32 `(N, 2)` pixel positions `(x, y)` from `p0` to `p1`, both
    included, `N = max(|dx|, |dy|) + 1`.
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    k = np.arange(d_major + 1, dtype=np.int64)
    minor = _bresenham_offsets(d_major, d_minor, k)
    return _assemble_line(start, x_major, s_major * k, s_minor * minor)


def line_bresenham_steps(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Textbook Bresenham (`lax.scan`) with the integer decision parameter.

    `p_0 = 2 dminor - dmajor`; at each step plot the pixel, then if `p_k >= 0` step the
    minor coordinate and `p -= 2 dmajor`; step the major coordinate and
    `p += 2 dminor`. Same arguments and result as `line_bresenham`.
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    major, minor = _bresenham_scan(d_major, d_minor, d_major + 1)
    return _assemble_line(start, x_major, s_major * major, s_minor * minor)


# --------------------------------------------------------------------------------------
# Circles and ellipses
# --------------------------------------------------------------------------------------


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
    center = center if isinstance(center, jax.Array) else np.asarray(center)
    check_shape(center, "center", (2,))
    if not jnp.issubdtype(center.dtype, jnp.integer):
        raise TypeError(f"`center` must be integer pixel coordinates (x, y), got dtype "
                        f"{center.dtype}")
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


def midpoint_circle(radius: int, *, center: tuple[int, int] = (0, 0)) -> Int[Array, "N 2"]:
    """The pixels of a circle by the midpoint circle algorithm, vectorized.

    The first octant (from `(0, r)` while `x <= y`) is computed in closed form: the
    midpoint algorithm keeps `(2y - 1)^2 < 4 (r^2 - x^2) <= (2y + 1)^2` at every column
    (see `midpoint_circle_steps` for the step-by-step version), so each column's `y` is
    an exact integer square root. The other seven octants follow by symmetry.

    **Arguments:**

    - `radius`: the radius, a static int in `[0, MAX_CIRCLE_RADIUS]`.
    - `center`: integer centre `(x, y)`; may be a traced integer array.

    **Returns:** int32 `(N, 2)` unique pixel positions `(x, y)` in clockwise order,
    starting just right of the top pixel `(xc, yc + r)` and ending on it (for `r = 0`
    the single pixel `center`). `N = 4 (n - 1)` where `n` is the number of pixels in
    one quadrant.
    """
    radius = _check_radius(radius, "radius", MAX_CIRCLE_RADIUS)
    center = _check_center(center)
    # The pixels depend only on static ints: a constant of the trace, computed in NumPy.
    return _circle_from_octant(_static_circle_octant(radius), radius, center)


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
    return _circle_trace_scan(radius, _circle_num_steps(radius))


def midpoint_circle_steps(radius: int, *, center: tuple[int, int] = (0, 0)) -> Int[Array, "N 2"]:
    """`midpoint_circle` from the step-by-step recurrence (`midpoint_circle_trace`).

    Same arguments and result (same pixels in the same order) as `midpoint_circle`.
    """
    radius = _check_radius(radius, "radius", MAX_CIRCLE_RADIUS)
    center = _check_center(center)
    with jax.ensure_compile_time_eval():
        rows = np.asarray(_circle_trace_scan(radius, _circle_num_steps(radius)))
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
        row = jnp.stack([
            jnp.where(in_region1, 1, 2),
            k,
            jnp.where(in_region1, p1, p2),
            jnp.where(in_region1, frac1, frac2),
            jnp.where(in_region1, x1, x2),
            jnp.where(in_region1, y1, y2),
            valid.astype(_INT),
        ])
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


def midpoint_ellipse(
    rx: int, ry: int, *, center: tuple[int, int] = (0, 0)
) -> Int[Array, "N 2"]:
    """The pixels of an axis-aligned ellipse by the midpoint ellipse algorithm, vectorized.

    Both regions of the textbook algorithm (region 1 steps x while the slope is above
    -1, region 2 steps y down to 0) are evaluated in closed form; see
    `midpoint_ellipse_steps` for the step-by-step version.

    **Arguments:**

    - `rx`, `ry`: semi-axes, static ints in `[1, MAX_ELLIPSE_RADIUS]`.
    - `center`: integer centre `(x, y)`; may be a traced integer array.

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
        rows = np.asarray(_ellipse_trace_scan(rx, ry, rx + ry + 2))
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


# --------------------------------------------------------------------------------------
# Polygon fill
# --------------------------------------------------------------------------------------


def _check_vertices(vertices, name: str = "vertices") -> jax.Array:
    vertices = as_float(vertices, name)
    check_last_dim(vertices, name, (2,), "polygon vertices (x, y)")
    if vertices.ndim < 2 or vertices.shape[-2] < 3:
        raise ValueError(
            f"`{name}` must have shape (..., V, 2) with at least 3 vertices, got shape "
            f"{tuple(vertices.shape)}"
        )
    return vertices


def inside_polygon(
    points: Float[Array, "*batch 2"], vertices: Float[Array, "V 2"]
) -> Bool[Array, "*batch"]:
    """Even-odd point-in-polygon test, vectorized over points and edges.

    A point is inside when a ray from it towards +x crosses the boundary an odd number
    of times. An edge counts when one endpoint is strictly above the point's y and the
    other is not (a half-open rule, so a ray through a vertex counts once).

    **Arguments:**

    - `points`: `(..., 2)` query points.
    - `vertices`: `(V, 2)` polygon vertices in order (closed implicitly, either
      orientation, self-intersections allowed).

    **Returns:** boolean `(...)`.
    """
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    points = as_float(points, "points")
    check_last_dim(points, "points", (2,), "points (x, y)")
    return _inside_polygon(points, vertices)


@jax.jit
def _inside_polygon(points, vertices):
    a = vertices
    b = jnp.roll(vertices, -1, axis=0)
    px = points[..., None, 0]
    py = points[..., None, 1]
    straddles = (a[:, 1] > py) != (b[:, 1] > py)
    dy = b[:, 1] - a[:, 1]
    safe_dy = jnp.where(straddles, dy, 1.0)
    x_cross = a[:, 0] + (py - a[:, 1]) * (b[:, 0] - a[:, 0]) / safe_dy
    crossings = jnp.sum(straddles & (px < x_cross), axis=-1)
    return crossings % 2 == 1


def fill_polygon(vertices: Float[Array, "V 2"], shape: tuple[int, int]) -> Bool[Array, "H W"]:
    """Fill a polygon: the pixels whose centres are inside it (even-odd rule), vectorized.

    **Arguments:**

    - `vertices`: `(V, 2)` vertices in pixel coordinates `(x, y)`, y up.
    - `shape`: the image shape `(H, W)` (static).

    **Returns:** a boolean `(H, W)` mask. `fill_polygon_scanline` gives the same mask
    scan line by scan line.
    """
    shape = static_shape(shape)
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    return inside_polygon(pixel_centers(shape, vertices.dtype), vertices)


def fill_polygon_scanline(
    vertices: Float[Array, "V 2"], shape: tuple[int, int]
) -> Bool[Array, "H W"]:
    """Textbook scan-line polygon fill (`lax.scan` over scan lines).

    For each scan line `y` (a row of pixel centres) intersect every edge that straddles
    it (half-open in y, so a vertex is counted once), sort the crossings and fill the
    pixel centres between crossings 1-2, 3-4, ... (left-closed, right-open).
    Same arguments and result as `fill_polygon`.
    """
    height, width = static_shape(shape)
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    return _fill_polygon_scanline(vertices, (height, width))


@jax.jit(static_argnames="shape")
def _fill_polygon_scanline(vertices, shape):
    height, width = shape
    a = vertices
    b = jnp.roll(vertices, -1, axis=0)
    xs = jnp.arange(width, dtype=vertices.dtype)

    def scan_line(_, y):
        straddles = (a[:, 1] > y) != (b[:, 1] > y)
        dy = jnp.where(straddles, b[:, 1] - a[:, 1], 1.0)
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / dy
        x_cross = jnp.sort(jnp.where(straddles, x_cross, jnp.inf))
        # A pixel is inside when an odd number of sorted crossings lie at or left of it.
        count = jnp.sum(x_cross[None, :] <= xs[:, None], axis=-1)
        return None, count % 2 == 1

    ys = (height - 1 - jnp.arange(height)).astype(vertices.dtype)
    _, rows = jax.lax.scan(scan_line, None, ys)
    return rows


# --------------------------------------------------------------------------------------
# Anti-aliasing
# --------------------------------------------------------------------------------------


def supersample(
    fn: Callable[[jax.Array], jax.Array], shape: tuple[int, int], *, factor: int = 4
) -> Float[Array, "H W"]:
    """Anti-alias by supersampling: average `fn` over a `factor x factor` grid per pixel.

    **Arguments:**

    - `fn`: maps points `(..., 2)` in pixel coordinates to values `(...)` (booleans
      for an inside test, or intensities).
    - `shape`: the image shape `(H, W)` (static).
    - `factor`: samples per pixel along each axis (static int >= 1); the samples sit at
      the centres of a regular `factor x factor` grid of sub-pixels.

    **Returns:** a float `(H, W)` image: the mean of `fn` over each pixel's samples.
    """
    if not callable(fn):
        raise TypeError(f"`fn` must be a function of points (..., 2), got {type(fn).__name__}")
    height, width = static_shape(shape)
    factor = static_int(factor, "factor", minimum=1)
    dtype = jnp.result_type(float)
    offsets = (jnp.arange(factor, dtype=dtype) + 0.5) / factor - 0.5
    ox, oy = jnp.meshgrid(offsets, offsets)
    sub = jnp.stack([ox.ravel(), oy.ravel()], -1)  # (factor^2, 2)
    samples = pixel_centers((height, width), dtype)[:, :, None, :] + sub
    values = jnp.asarray(fn(samples))
    if values.shape != (height, width, factor * factor):
        raise ValueError(
            f"`fn` must map points of shape (..., 2) to values of shape (...), got "
            f"{values.shape} for points of shape {samples.shape}"
        )
    return jnp.mean(values.astype(dtype), axis=-1)


def _clamped_integral(x, lo, hi):
    """Antiderivative of `clamp(x, lo, hi) - lo`, zero at `x = lo`."""
    below = x < lo
    above = x > hi
    inner = 0.5 * (x - lo) ** 2
    full = 0.5 * (hi - lo) ** 2 + (hi - lo) * (x - hi)
    return jnp.where(below, 0.0, jnp.where(above, full, inner))


def polygon_coverage(
    vertices: Float[Array, "*batch V 2"], shape: tuple[int, int]
) -> Float[Array, "*batch H W"]:
    """Exact area of each pixel covered by a polygon: analytic anti-aliasing.

    By Green's theorem the area of a polygon inside a box `[x0, x1] x [y0, y1]` is the
    boundary integral of `(clamp(x, x0, x1) - x0) d clamp(y, y0, y1)`; along a straight
    edge that integral has a closed form. Every pixel and every edge are evaluated at
    once. Differentiable in `vertices` (gradients flow through edges crossing pixels).

    **Arguments:**

    - `vertices`: `(..., V, 2)` vertices of a simple polygon (either orientation) in
      pixel coordinates, y up.
    - `shape`: the image shape `(H, W)` (static).

    **Returns:** float `(..., H, W)` coverage in `[0, 1]`.
    """
    shape = static_shape(shape)
    return _polygon_coverage(_check_vertices(vertices), shape)


@jax.jit(static_argnames="shape")
def _polygon_coverage(vertices, shape):
    centres = pixel_centers(shape, vertices.dtype)
    x0 = centres[..., 0][..., None] - 0.5
    y0 = centres[..., 1][..., None] - 0.5
    x1, y1 = x0 + 1.0, y0 + 1.0
    a = vertices[..., None, None, :, :]  # (..., 1, 1, V, 2)
    b = jnp.roll(vertices, -1, axis=-2)[..., None, None, :, :]
    ax, ay, bx, by = a[..., 0], a[..., 1], b[..., 0], b[..., 1]
    dy = by - ay
    flat = jnp.abs(dy) == 0
    safe_dy = jnp.where(flat, 1.0, dy)
    # Clip the edge to the pixel's band of y; a horizontal edge contributes nothing.
    ya = jnp.clip(ay, y0, y1)
    yb = jnp.clip(by, y0, y1)
    xa = ax + (ya - ay) * (bx - ax) / safe_dy
    xb = ax + (yb - ay) * (bx - ax) / safe_dy
    dx = xb - xa
    close = jnp.abs(dx) < 1e-9
    safe_dx = jnp.where(close, 1.0, dx)
    mean_g = jnp.where(
        close,
        jnp.clip(0.5 * (xa + xb), x0, x1) - x0,
        (_clamped_integral(xb, x0, x1) - _clamped_integral(xa, x0, x1)) / safe_dx,
    )
    signed = jnp.sum(jnp.where(flat, 0.0, (yb - ya) * mean_g), axis=-1)
    # Orientation from the shoelace area, so either vertex order gives positive coverage.
    shoelace = jnp.sum(
        vertices[..., 0] * jnp.roll(vertices[..., 1], -1, axis=-1)
        - jnp.roll(vertices[..., 0], -1, axis=-1) * vertices[..., 1],
        axis=-1,
    )
    orientation = jnp.where(shoelace < 0, -1.0, 1.0)[..., None, None]
    return jnp.clip(orientation * signed, 0.0, 1.0)


def line_coverage(
    p0: Float[Array, "*batch 2"],
    p1: Float[Array, "*batch 2"],
    shape: tuple[int, int],
    *,
    width: float = 1.0,
) -> Float[Array, "*batch H W"]:
    """Exact area coverage of a thick line: the `width`-wide rectangle around `p0 -> p1`.

    **Arguments:**

    - `p0`, `p1`: endpoints `(..., 2)` in pixel coordinates (traced, differentiable).
    - `shape`: the image shape `(H, W)` (static).
    - `width`: the line's thickness in pixels (> 0).

    **Returns:** float `(..., H, W)` coverage in `[0, 1]`.
    """
    p0 = as_float(p0, "p0")
    p1 = as_float(p1, "p1")
    check_last_dim(p0, "p0", (2,), "a point (x, y)")
    check_last_dim(p1, "p1", (2,), "a point (x, y)")
    width = as_float(width, "width")
    width = value_error_if(width, width <= 0, "`width` must be > 0")
    d = p1 - p0
    length_sq = jnp.sum(d * d, axis=-1, keepdims=True)
    positive = length_sq > 0
    length = jnp.sqrt(jnp.where(positive, length_sq, 1.0))
    direction = jnp.where(positive, d / length, jnp.array([1.0, 0.0], d.dtype))
    normal = jnp.stack([-direction[..., 1], direction[..., 0]], -1) * (0.5 * width)
    rect = jnp.stack([p0 - normal, p1 - normal, p1 + normal, p0 + normal], axis=-2)
    return polygon_coverage(rect, shape)


# --------------------------------------------------------------------------------------
# Displays: raster scan and random scan
# --------------------------------------------------------------------------------------


class BeamPath(NamedTuple):
    """Where a CRT's electron beam is at each time step, and how bright it is.

    - `positions`: `(T, 2)` beam position in pixel coordinates `(x, y)`, y up.
    - `intensity`: `(T,)` beam intensity in `[0, 1]` (0 while blanked).
    - `on`: `(T,)` whether the beam is switched on (off during retrace and moves).
    """

    positions: Float[Array, "T 2"]
    intensity: Float[Array, " T"]
    on: Bool[Array, " T"]


def _blanked_move(start: np.ndarray, end: np.ndarray, steps: int) -> np.ndarray:
    t = (np.arange(steps) + 1.0) / (steps + 1)
    return start + t[:, None] * (end - start)


def raster_scan(
    frame_buffer: Float[Array, "H W"],
    *,
    interlaced: bool = False,
    h_retrace: int = 4,
    v_retrace: int = 12,
) -> BeamPath:
    """One refresh of a raster-scan display: the beam sweeps every scan line of the frame
    buffer left to right, top to bottom, and is blanked during the retraces.

    After each scan line the beam flies back to the start of the next one (horizontal
    retrace, `h_retrace` steps); after the last line of a field it flies back to the top
    (vertical retrace, `v_retrace` steps). With `interlaced=True` a refresh is two
    fields: the even rows (0, 2, 4, ... from the top), then the odd rows.

    **Arguments:**

    - `frame_buffer`: `(H, W)` intensities in `[0, 1]`; row 0 is the top scan line.
    - `interlaced`: scan even rows, then odd rows (static).
    - `h_retrace`, `v_retrace`: time steps of the horizontal and vertical retraces
      (static ints >= 1).

    **Returns:** a `BeamPath` with `T = H W + (H - F) h_retrace + F v_retrace` steps
    (`F` fields), one time step per pixel while the beam is on.
    """
    frame_buffer = as_float(frame_buffer, "frame_buffer")
    check_shape(frame_buffer, "frame_buffer", (None, None))
    height, width = frame_buffer.shape
    h_retrace = static_int(h_retrace, "h_retrace", minimum=1)
    v_retrace = static_int(v_retrace, "v_retrace", minimum=1)
    if interlaced:
        fields = [np.arange(0, height, 2), np.arange(1, height, 2)]
    else:
        fields = [np.arange(height)]
    fields = [f for f in fields if f.size]
    rows_all, cols_all, pos_all, on_all = [], [], [], []
    xs = np.arange(width, dtype=float)
    for i, rows in enumerate(fields):  # one or two fields, not a loop over pixels
        n = rows.size
        y = (height - 1 - rows).astype(float)
        line_pos = np.stack(np.broadcast_arrays(xs[None, :], y[:, None]), -1)  # (n, W, 2)
        line_end = np.stack([np.full(n, width - 1.0), y], -1)
        next_start = np.stack([np.zeros(n), np.roll(y, -1)], -1)
        t = (np.arange(h_retrace) + 1.0) / (h_retrace + 1)
        retrace = line_end[:, None] + t[None, :, None] * (next_start - line_end)[:, None]
        block = np.concatenate([line_pos, retrace], axis=1).reshape(-1, 2)[:-h_retrace]
        block_on = np.concatenate(
            [np.ones((n, width), bool), np.zeros((n, h_retrace), bool)], axis=1
        ).ravel()[:-h_retrace]
        block_rows = np.concatenate(
            [np.repeat(rows[:, None], width, 1), np.zeros((n, h_retrace), int)], axis=1
        ).ravel()[:-h_retrace]
        block_cols = np.concatenate(
            [np.repeat(np.arange(width)[None], n, 0), np.zeros((n, h_retrace), int)], axis=1
        ).ravel()[:-h_retrace]
        first_next = fields[(i + 1) % len(fields)][0]
        vertical = _blanked_move(
            np.array([width - 1.0, y[-1]]), np.array([0.0, height - 1.0 - first_next]), v_retrace
        )
        pos_all += [block, vertical]
        on_all += [block_on, np.zeros(v_retrace, bool)]
        rows_all += [block_rows, np.zeros(v_retrace, int)]
        cols_all += [block_cols, np.zeros(v_retrace, int)]
    on = jnp.asarray(np.concatenate(on_all))
    rows = jnp.asarray(np.concatenate(rows_all))
    cols = jnp.asarray(np.concatenate(cols_all))
    intensity = jnp.where(on, frame_buffer[rows, cols], 0.0)
    positions = jnp.asarray(np.concatenate(pos_all), frame_buffer.dtype)
    return BeamPath(positions, intensity, on)


def random_scan(
    display_list: Float[Array, "S 2 2"],
    *,
    intensity: Float[Array, " S"] | None = None,
    samples_per_segment: int = 16,
    move_samples: int = 4,
) -> BeamPath:
    """One refresh of a random-scan (vector) display: the beam draws each line segment of
    the display list in turn, blanked while it moves to the next segment's start; after
    the last segment it returns to the first, and the list is redrawn every refresh.

    **Arguments:**

    - `display_list`: `(S, 2, 2)` segments `((x0, y0), (x1, y1))` in pixel coordinates.
    - `intensity`: `(S,)` brightness of each segment (default 1).
    - `samples_per_segment`: time steps spent drawing each segment (static int >= 2).
    - `move_samples`: time steps of each blanked move (static int >= 1).

    **Returns:** a `BeamPath` with `T = S (samples_per_segment + move_samples)` steps.
    """
    segments = as_float(display_list, "display_list")
    check_shape(segments, "display_list", (None, 2, 2))
    if segments.shape[0] < 1:
        raise ValueError("`display_list` must hold at least one segment")
    samples = static_int(samples_per_segment, "samples_per_segment", minimum=2)
    moves = static_int(move_samples, "move_samples", minimum=1)
    count = segments.shape[0]
    if intensity is None:
        intensity = jnp.ones(count, segments.dtype)
    intensity = as_float(intensity, "intensity")
    check_shape(intensity, "intensity", (count,))
    t = jnp.linspace(0.0, 1.0, samples, dtype=segments.dtype)
    p0, p1 = segments[:, 0], segments[:, 1]
    draw = p0[:, None] + t[None, :, None] * (p1 - p0)[:, None]  # (S, samples, 2)
    next_start = jnp.roll(p0, -1, axis=0)
    u = (jnp.arange(moves, dtype=segments.dtype) + 1.0) / (moves + 1)
    move = p1[:, None] + u[None, :, None] * (next_start - p1)[:, None]
    positions = jnp.concatenate([draw, move], axis=1).reshape(-1, 2)
    on = jnp.concatenate([jnp.ones((count, samples), bool), jnp.zeros((count, moves), bool)], 1)
    level = jnp.concatenate(
        [jnp.broadcast_to(intensity[:, None], (count, samples)), jnp.zeros((count, moves))], 1
    )
    return BeamPath(positions, level.ravel().astype(segments.dtype), on.ravel())


def phosphor_frames(
    beam: BeamPath,
    shape: tuple[int, int],
    *,
    num_frames: int = 8,
    decay: float = 0.98,
    refreshes: int = 1,
) -> Float[Array, "F H W"]:
    """What the screen shows over time: the beam excites the phosphor at its position,
    and the glow decays by `decay` per time step (persistence).

    **Arguments:**

    - `beam`: a `BeamPath` from `raster_scan` or `random_scan` (one refresh).
    - `shape`: the screen shape `(H, W)` (static).
    - `num_frames`: snapshots, evenly spaced over the whole run (static int >= 1).
    - `decay`: glow kept per time step, in `(0, 1]`.
    - `refreshes`: how many times the beam path repeats (static int >= 1).

    **Returns:** float `(num_frames, H, W)` screen images in `[0, 1]`, the last one at
    the end of the run.
    """
    if not isinstance(beam, BeamPath):
        raise TypeError(f"`beam` must be a BeamPath, got {type(beam).__name__}")
    height, width = static_shape(shape)
    num_frames = static_int(num_frames, "num_frames", minimum=1)
    refreshes = static_int(refreshes, "refreshes", minimum=1)
    decay = as_float(decay, "decay")
    decay = value_error_if(decay, (decay <= 0) | (decay > 1), "`decay` must be in (0, 1]")
    return _phosphor_frames(beam, decay, (height, width), num_frames, refreshes)


@jax.jit(static_argnames=("shape", "num_frames", "refreshes"))
def _phosphor_frames(beam, decay, shape, num_frames, refreshes):
    height, width = shape
    positions = jnp.tile(beam.positions, (refreshes, 1))
    level = jnp.tile(jnp.where(beam.on, beam.intensity, 0.0), refreshes)
    steps = positions.shape[0]
    cells = pixel_to_index(jnp.round(positions).astype(_INT), (height, width))
    rows, cols = cells[:, 0], cells[:, 1]
    inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
    flat = jnp.where(inside, cells[:, 0] * width + cells[:, 1], height * width)
    times = jnp.arange(steps)
    snaps = jnp.round(jnp.linspace(steps / num_frames, steps, num_frames)).astype(_INT) - 1
    age = snaps[:, None] - times[None, :]
    weights = jnp.where(age >= 0, decay ** jnp.maximum(age, 0), 0.0) * level[None, :]

    def one_frame(w):
        image = jax.ops.segment_sum(w, flat, num_segments=height * width + 1)[:-1]
        return image.reshape(height, width)

    return jnp.clip(jax.vmap(one_frame)(weights), 0.0, 1.0)

